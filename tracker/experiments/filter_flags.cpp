// The filter's options as mocap-experiment flags (see filter_flags.h).
#include "tracker/experiments/filter_flags.h"

#include <stdexcept>
#include <string_view>

namespace mocap {
namespace {

bool setByTheExperiment(std::string_view key) { return key == "evaluations" || key == "seed"; }

std::string flagOf(std::string key) {
  for (char& c : key)
    if (c == '_') c = '-';
  return key;
}

}  // namespace

std::string filterFlagsUsage(const std::string& indent) {
  std::string usage = indent, line;
  for (const FilterOptionKey& option : filterOptionKeys()) {
    if (setByTheExperiment(option.key)) continue;
    const std::string flag = "[--" + flagOf(option.key) + " " + option.values + "]";
    if (!line.empty() && indent.size() + line.size() + 1 + flag.size() > 100) {
      usage += line + "\n" + indent;
      line.clear();
    }
    line += (line.empty() ? "" : " ") + flag;
  }
  return usage + line;
}

void readFilterFlags(const Args& args, FilterOptions& options) {
  for (const FilterOptionKey& option : filterOptionKeys()) {
    const std::string flag = flagOf(option.key);
    if (setByTheExperiment(option.key) || !args.has(flag)) continue;
    try {
      option.set(options, args.text(flag, ""));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("--" + flag + ": " + e.what());
    }
  }
  validateFilterOptions(options);
}

}  // namespace mocap
