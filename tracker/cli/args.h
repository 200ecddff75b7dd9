// Minimal command-line flags for the experiment commands: "--name value" pairs and "--switch",
// taken from the command's usage text, with errors that name the flag.
#pragma once

#include <cctype>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

namespace mocap {

class Args {
 public:
  // The flags are read off `usage`, the command's usage text, so the text a user is shown and the
  // flags accepted cannot drift apart: "--name WORD" (WORD a placeholder) takes a value; "--name"
  // followed by "]", a line break, " [" or the end is a switch; any other mention ("--name:" in
  // a remark) declares nothing.
  Args(int argc, char** argv, int first, std::string_view usage) {
    std::set<std::string> known, switches;
    auto in_name = [](char c) {
      return std::islower(static_cast<unsigned char>(c)) ||
             std::isdigit(static_cast<unsigned char>(c)) || c == '-';
    };
    for (std::size_t at = usage.find("--"); at != std::string_view::npos;
         at = usage.find("--", at)) {
      std::size_t end = at + 2;
      while (end < usage.size() && in_name(usage[end])) ++end;
      const std::string name(usage.substr(at + 2, end - at - 2));
      const char next = end < usage.size() ? usage[end] : '\n';
      const char after = end + 1 < usage.size() ? usage[end + 1] : '\n';
      if (next == ' ' && after != '[' && after != '\n' && after != ' ')
        known.insert(name);
      else if (next == ']' || next == '\n' || (next == ' ' && after == '['))
        switches.insert(name);
      at = end;
    }
    for (const std::string& name : known) switches.erase(name);
    for (int i = first; i < argc; ++i) {
      std::string flag = argv[i];
      if (flag.rfind("--", 0) != 0)
        throw std::invalid_argument("unexpected argument '" + flag + "'");
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
    if (!(v >= min && v <= max)) {
      std::ostringstream range;
      range << "[" << min << ", " << max << "]";  // 0.5, not 0.500000
      throw std::invalid_argument("--" + flag + ": " + it->second + " is outside " + range.str());
    }
    return v;
  }

 private:
  std::map<std::string, std::string> values_;
};

}  // namespace mocap
