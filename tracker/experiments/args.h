// Minimal command-line flags for the experiment commands: "--name value" pairs and "--switch",
// with errors that name the flag.
#pragma once

#include <map>
#include <set>
#include <stdexcept>
#include <string>

namespace mocap {

class Args {
 public:
  // `switches` take no value; every other flag in `known` takes one.
  Args(int argc, char** argv, int first, const std::set<std::string>& known,
       const std::set<std::string>& switches) {
    for (int i = first; i < argc; ++i) {
      std::string flag = argv[i];
      if (flag.rfind("--", 0) != 0) throw std::invalid_argument("unexpected argument '" + flag + "'");
      flag = flag.substr(2);
      if (!known.count(flag) && !switches.count(flag))
        throw std::invalid_argument("unknown flag --" + flag);
      if (switches.count(flag)) {
        values_[flag] = "1";
        continue;
      }
      if (i + 1 >= argc) throw std::invalid_argument("--" + flag + " needs a value");
      values_[flag] = argv[++i];
    }
  }

  bool has(const std::string& flag) const { return values_.count(flag) > 0; }
  std::string text(const std::string& flag, const std::string& fallback) const {
    auto it = values_.find(flag);
    return it == values_.end() ? fallback : it->second;
  }
  long integer(const std::string& flag, long fallback, long min, long max) const {
    auto it = values_.find(flag);
    if (it == values_.end()) return fallback;
    std::size_t used = 0;
    long v = 0;
    try {
      v = std::stol(it->second, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != it->second.size())
      throw std::invalid_argument("--" + flag + ": not an integer: '" + it->second + "'");
    if (v < min || v > max)
      throw std::invalid_argument("--" + flag + ": " + it->second + " is outside [" +
                                  std::to_string(min) + ", " + std::to_string(max) + "]");
    return v;
  }
  double real(const std::string& flag, double fallback, double min, double max) const {
    auto it = values_.find(flag);
    if (it == values_.end()) return fallback;
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(it->second, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != it->second.size())
      throw std::invalid_argument("--" + flag + ": not a number: '" + it->second + "'");
    if (!(v >= min && v <= max))
      throw std::invalid_argument("--" + flag + ": " + it->second + " is outside [" +
                                  std::to_string(min) + ", " + std::to_string(max) + "]");
    return v;
  }

 private:
  std::map<std::string, std::string> values_;
};

}  // namespace mocap
