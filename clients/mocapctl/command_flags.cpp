// Flag handling and the progress line shared by mocapctl subcommands.
#include "clients/mocapctl/command_flags.h"

#include <unistd.h>

#include <iostream>
#include <stdexcept>

namespace mocapctl {

long positiveNumber(const std::string& flag, const std::string& text) {
  try {
    std::size_t used = 0;
    const long value = std::stol(text, &used);
    if (used == text.size() && value > 0) return value;
  } catch (const std::exception&) {
  }
  throw std::runtime_error(flag + ": expected a positive whole number, got '" + text + "'");
}

std::string takeFlag(std::vector<std::string>& args, const std::string& name) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] != name) continue;
    if (i + 1 >= args.size()) throw std::runtime_error(name + " needs a value");
    std::string value = args[i + 1];
    args.erase(args.begin() + static_cast<std::ptrdiff_t>(i),
               args.begin() + static_cast<std::ptrdiff_t>(i) + 2);
    return value;
  }
  return "";
}

bool takeSwitch(std::vector<std::string>& args, const std::string& name) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] != name) continue;
    args.erase(args.begin() + static_cast<std::ptrdiff_t>(i));
    return true;
  }
  return false;
}

void noMoreArguments(const std::vector<std::string>& args) {
  if (!args.empty()) throw std::runtime_error("unexpected argument '" + args.front() + "'");
}

void progress(const std::string& text) {
  static const bool terminal = isatty(STDERR_FILENO) == 1;
  if (terminal) {
    std::cerr << "\r" << text << std::flush;
  } else {
    std::cerr << text << "\n";
  }
}

}  // namespace mocapctl
