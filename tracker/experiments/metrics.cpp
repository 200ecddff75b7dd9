// Tracking error measures.
#include "tracker/experiments/metrics.h"

#include <algorithm>

namespace mocap {

std::vector<double> relativeErrorPerPoint(const PointTrack& truth, const PointTrack& tracked,
                                          double min_amplitude) {
  const std::size_t points = truth.empty() ? 0 : truth[0].size();
  std::vector<double> out(points, -1.0);
  const std::vector<double> mean_error = meanErrorPerPoint(truth, tracked);
  for (std::size_t p = 0; p < points; ++p) {
    double amplitude = 0;
    for (std::size_t a = 0; a < truth.size(); ++a)
      for (std::size_t b = a + 1; b < truth.size(); ++b)
        amplitude = std::max(amplitude, (truth[a][p] - truth[b][p]).norm());
    if (amplitude >= min_amplitude) out[p] = mean_error[p] / amplitude;
  }
  return out;
}

std::vector<double> meanErrorPerPoint(const PointTrack& truth, const PointTrack& tracked) {
  const std::size_t points = truth.empty() ? 0 : truth[0].size();
  std::vector<double> out(points, 0.0);
  if (truth.empty()) return out;
  for (std::size_t f = 0; f < truth.size(); ++f)
    for (std::size_t p = 0; p < points; ++p) out[p] += (truth[f][p] - tracked[f][p]).norm();
  for (double& e : out) e /= static_cast<double>(truth.size());
  return out;
}

}  // namespace mocap
