// Motion generation and CSV I/O.
#include "tracker/motion/motion.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

namespace mocap {

Motion generateMotion(const BodyModel& model, int frames, uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto uniform = [&rng](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  const std::size_t n = model.dofs.size();
  Eigen::VectorXd q(n), v = Eigen::VectorXd::Zero(n), target(n), cap(n);
  std::vector<int> age(n, 0);
  auto pickTarget = [&](std::size_t d) {
    const Dof& dof = model.dofs[d];
    const double margin = 0.05 * (dof.max - dof.min);
    target[d] = uniform(dof.min + margin, dof.max - margin);
    cap[d] = uniform(0.5, 0.97) * dof.max_speed;
    age[d] = 0;
  };
  for (std::size_t d = 0; d < n; ++d) {
    const Dof& dof = model.dofs[d];
    const double margin = 0.15 * (dof.max - dof.min);
    q[d] = uniform(dof.min + margin, dof.max - margin);
    pickTarget(d);
  }
  Motion motion;
  motion.reserve(frames);
  for (int f = 0; f < frames; ++f) {
    motion.push_back(q);
    for (std::size_t d = 0; d < n; ++d) {
      const Dof& dof = model.dofs[d];
      const double range = dof.max - dof.min;
      if (std::abs(target[d] - q[d]) < 0.03 * range || ++age[d] > 75) pickTarget(d);
      const double accel = 0.2 * dof.max_speed;
      const double wanted = std::clamp(0.3 * (target[d] - q[d]), -cap[d], cap[d]);
      v[d] += std::clamp(wanted - v[d], -accel, accel);
      q[d] = std::clamp(q[d] + v[d], dof.min, dof.max);
    }
  }
  return motion;
}

namespace {

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) {
    const auto first = cell.find_first_not_of(" \t\r");
    const auto last = cell.find_last_not_of(" \t\r");
    cells.push_back(first == std::string::npos ? "" : cell.substr(first, last - first + 1));
  }
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

}  // namespace

Motion loadMotionCsv(const std::string& path, const BodyModel& model) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open motion file");
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(path + ": empty file, expected a header");
  const std::vector<std::string> header = splitCsv(line);
  std::vector<int> dof_of_column(header.size());
  std::vector<bool> seen(model.dofs.size(), false);
  for (std::size_t c = 0; c < header.size(); ++c) {
    const int d = model.dofIndex(header[c]);
    if (d < 0)
      throw std::runtime_error(path + ":1: column " + std::to_string(c + 1) + ": unknown DOF '" +
                               header[c] + "'");
    if (seen[d])
      throw std::runtime_error(path + ":1: column " + std::to_string(c + 1) + ": DOF '" +
                               header[c] + "' appears twice");
    seen[d] = true;
    dof_of_column[c] = d;
  }
  for (std::size_t d = 0; d < seen.size(); ++d)
    if (!seen[d])
      throw std::runtime_error(path + ":1: missing column for DOF '" + model.dofs[d].name + "'");

  Motion motion;
  for (int line_no = 2; std::getline(in, line); ++line_no) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> cells = splitCsv(line);
    const std::string where = path + ":" + std::to_string(line_no);
    if (cells.size() != header.size())
      throw std::runtime_error(where + ": " + std::to_string(cells.size()) + " values, expected " +
                               std::to_string(header.size()));
    Eigen::VectorXd q(model.dofs.size());
    for (std::size_t c = 0; c < cells.size(); ++c) {
      const std::string col = where + ": column " + std::to_string(c + 1) + " (" + header[c] + ")";
      double value = 0;
      std::size_t used = 0;
      try {
        value = std::stod(cells[c], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != cells[c].size() || !std::isfinite(value))
        throw std::runtime_error(col + ": not a number: '" + cells[c] + "'");
      const Dof& dof = model.dofs[dof_of_column[c]];
      if (value < dof.min - 1e-9 || value > dof.max + 1e-9) {
        std::ostringstream msg;
        msg << col << ": " << value << " is outside the limits [" << dof.min << ", " << dof.max
            << "]";
        throw std::runtime_error(msg.str());
      }
      q[dof_of_column[c]] = value;
    }
    motion.push_back(q);
  }
  if (motion.empty()) throw std::runtime_error(path + ": no frames after the header");
  return motion;
}

void saveMotionCsv(const std::string& path, const BodyModel& model, const Motion& motion) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  for (std::size_t d = 0; d < model.dofs.size(); ++d) out << (d ? "," : "") << model.dofs[d].name;
  out << "\n";
  out.precision(17);
  for (const Eigen::VectorXd& q : motion) {
    for (long d = 0; d < q.size(); ++d) out << (d ? "," : "") << q[d];
    out << "\n";
  }
}

}  // namespace mocap
