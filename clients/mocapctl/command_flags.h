// Flag handling shared by the mocapctl subcommands that take a positional argument or daemon flags
// (and so cannot use mocap::Args), and their progress line on stderr.
#pragma once

#include <string>
#include <vector>

namespace mocapctl {

// `text` as a whole number above zero; throws std::runtime_error naming `flag` otherwise.
long positiveNumber(const std::string& flag, const std::string& text);

// Takes "--name VALUE" out of `args`; empty if absent. Throws if the value is missing.
std::string takeFlag(std::vector<std::string>& args, const std::string& name);

// Takes "--name" out of `args`; whether it was there.
bool takeSwitch(std::vector<std::string>& args, const std::string& name);

// Throws std::runtime_error naming the first of `args`, if any is left.
void noMoreArguments(const std::vector<std::string>& args);

// One line on stderr for commands that run for a while: rewritten in place on a terminal, one line
// per update when stderr is a file or a pipe.
void progress(const std::string& text);

}  // namespace mocapctl
