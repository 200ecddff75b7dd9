// The filter's options as mocap-experiment flags: --key-name VALUES for each key of the options
// table (tracker/filters/filter_options.h) but the two the experiments set themselves (--evals,
// --seed), so an experiment takes exactly the options the daemon's `tracker:` keys take.
#pragma once

#include <string>

#include "tracker/cli/args.h"
#include "tracker/filters/filter_options.h"

namespace mocap {

// The flags as usage text, "[--keep 1-100000] [--samples 0-100000] ...", in lines that start with
// `indent`.
std::string filterFlagsUsage(const std::string& indent);

// Sets every option whose flag `args` has; throws std::invalid_argument "--flag: ..." on a bad one.
void readFilterFlags(const Args& args, FilterOptions& options);

}  // namespace mocap
