// The table of the filters' option keys, their text forms and ranges (see filter_options.h).
#include "tracker/filters/filter_options.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace mocap {
namespace {

[[noreturn]] void expected(const std::string& what, const std::string& text) {
  throw std::invalid_argument("expected " + what + ", got '" + text + "'");
}

template <typename T>
[[noreturn]] void outside(T lo, T hi, const std::string& text) {
  std::ostringstream out;
  out << "must be between " << lo << " and " << hi << ", got '" << text << "'";
  throw std::invalid_argument(out.str());
}

long long integerIn(const std::string& text, long long lo, long long hi) {
  long long value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error == std::errc::result_out_of_range) outside(lo, hi, text);
  if (error != std::errc() || end != text.data() + text.size()) expected("a whole number", text);
  if (value < lo || value > hi) outside(lo, hi, text);
  return value;
}

double realIn(const std::string& text, double lo, double hi) {
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::out_of_range&) {
    outside(lo, hi, text);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) expected("a number", text);
  if (!(value >= lo && value <= hi)) outside(lo, hi, text);
  return value;
}

// YAML's words for a boolean, and 0 and 1 (the experiments' flags).
bool boolean(const std::string& text) {
  std::string word = text;
  std::transform(word.begin(), word.end(), word.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (word == "true" || word == "yes" || word == "on" || word == "1") return true;
  if (word == "false" || word == "no" || word == "off" || word == "0") return false;
  expected("true or false", text);
}

std::string yesNo(bool value) { return value ? "true" : "false"; }

// The table. Ranges live in the setters alone; validateFilterOptions reads every option back
// through them.
const std::vector<FilterOptionKey> kKeys = {
    {"evaluations", "1-10000000", "particle evaluations per frame, as the paper counts them",
     [](FilterOptions& o, const std::string& t) {
       o.evaluations_per_frame = static_cast<int>(integerIn(t, 1, 10'000'000));
     },
     [](const FilterOptions& o) { return std::to_string(o.evaluations_per_frame); }},
    {"keep", "1-100000", "factored: the K best candidates kept per layer",
     [](FilterOptions& o, const std::string& t) {
       o.keep = static_cast<int>(integerIn(t, 1, 100'000));
     },
     [](const FilterOptions& o) { return std::to_string(o.keep); }},
    {"samples", "0-100000", "factored: S samples per interval; 0: derived from the budget",
     [](FilterOptions& o, const std::string& t) {
       o.samples = static_cast<int>(integerIn(t, 0, 100'000));
     },
     [](const FilterOptions& o) { return std::to_string(o.samples); }},
    {"injection", "0-0.99", "factored: share of candidates from the static distribution",
     [](FilterOptions& o, const std::string& t) { o.injection.share = realIn(t, 0, 0.99); },
     [](const FilterOptions& o) { return shortestText(o.injection.share); }},
    {"inject", "dof|segment",
     "factored: what an injected candidate redraws: the layer's DOF (the paper) or all of a "
     "segment's angles",
     [](FilterOptions& o, const std::string& t) {
       if (t == "dof") {
         o.injection.redraw = InjectionOptions::Redraw::kDof;
       } else if (t == "segment") {
         o.injection.redraw = InjectionOptions::Redraw::kSegment;
       } else {
         expected("dof or segment", t);
       }
     },
     [](const FilterOptions& o) -> std::string {
       return o.injection.redraw == InjectionOptions::Redraw::kSegment ? "segment" : "dof";
     }},
    {"lookahead", "none|body",
     "factored: what a layer ranks its candidates by: its segment (the paper) or the whole body",
     [](FilterOptions& o, const std::string& t) {
       if (t == "none") {
         o.lookahead = FilterOptions::Lookahead::kNone;
       } else if (t == "body") {
         o.lookahead = FilterOptions::Lookahead::kBody;
       } else {
         expected("none or body", t);
       }
     },
     [](const FilterOptions& o) -> std::string {
       return o.lookahead == FilterOptions::Lookahead::kBody ? "body" : "none";
     }},
    {"refine", "0-0.99", "factored: share of the budget spent on the full-body refinement",
     [](FilterOptions& o, const std::string& t) { o.refine.share = realIn(t, 0, 0.99); },
     [](const FilterOptions& o) { return shortestText(o.refine.share); }},
    {"refine_max", "0-10000000", "refinement: at most this many evaluations a frame; 0: no cap",
     [](FilterOptions& o, const std::string& t) {
       o.refine.max_evaluations = static_cast<int>(integerIn(t, 0, 10'000'000));
     },
     [](const FilterOptions& o) { return std::to_string(o.refine.max_evaluations); }},
    {"refine_hold", "true|false",
     "refinement: turn segments with their ball-joint children held in the world",
     [](FilterOptions& o, const std::string& t) { o.refine.hold = boolean(t); },
     [](const FilterOptions& o) { return yesNo(o.refine.hold); }},
    {"refine_plant", "true|false", "refinement: move the pelvis with the feet planted",
     [](FilterOptions& o, const std::string& t) { o.refine.plant = boolean(t); },
     [](const FilterOptions& o) { return yesNo(o.refine.plant); }},
    {"refine_swap", "true|false|knees",
     "refinement: try the legs' angles exchanged each frame (knees: only the knees')",
     [](FilterOptions& o, const std::string& t) {
       o.refine.swap.knees_only = t == "knees";
       if (o.refine.swap.knees_only) {
         o.refine.swap.enabled = true;
         return;
       }
       try {
         o.refine.swap.enabled = boolean(t);
       } catch (const std::invalid_argument&) {
         expected("true, false or knees", t);
       }
     },
     [](const FilterOptions& o) -> std::string {
       if (!o.refine.swap.enabled) return "false";
       return o.refine.swap.knees_only ? "knees" : "true";
     }},
    {"refine_swap_margin", "0-10000000",
     "refinement: silhouette pixels an exchanged pose must gain to replace the pose",
     [](FilterOptions& o, const std::string& t) { o.refine.swap.margin = realIn(t, 0, 1e7); },
     [](const FilterOptions& o) { return shortestText(o.refine.swap.margin); }},
    {"refine_restarts", "0-1", "refinement: share spent restarting one limb a frame",
     [](FilterOptions& o, const std::string& t) { o.refine.restart_share = realIn(t, 0, 1); },
     [](const FilterOptions& o) { return shortestText(o.refine.restart_share); }},
    {"refine_facing_prior", "0-1000000",
     "refinement: weight of the prior that the pelvis faces where the legs do",
     [](FilterOptions& o, const std::string& t) { o.refine.facing_prior = realIn(t, 0, 1e6); },
     [](const FilterOptions& o) { return shortestText(o.refine.facing_prior); }},
    {"refine_uncross", "0-1000000",
     "refinement: weight of the cost on crossed feet, and the move that uncrosses them",
     [](FilterOptions& o, const std::string& t) { o.refine.uncross = realIn(t, 0, 1e6); },
     [](const FilterOptions& o) { return shortestText(o.refine.uncross); }},
    {"refine_unexplained", "true|false",
     "refinement: aim the legs at the silhouette the pose leaves unexplained",
     [](FilterOptions& o, const std::string& t) { o.refine.unexplained = boolean(t); },
     [](const FilterOptions& o) { return yesNo(o.refine.unexplained); }},
    {"layers", "1-100", "annealed: annealing layers per frame",
     [](FilterOptions& o, const std::string& t) {
       o.annealing_layers = static_cast<int>(integerIn(t, 1, 100));
     },
     [](const FilterOptions& o) { return std::to_string(o.annealing_layers); }},
    {"beta", "1e-09-1000", "the likelihood's log-likelihood per silhouette pixel",
     [](FilterOptions& o, const std::string& t) { o.likelihood.beta = realIn(t, 1e-9, 1e3); },
     [](const FilterOptions& o) { return shortestText(o.likelihood.beta); }},
    {"seed", "0-4611686018427387904", "the filters' random seed: they are deterministic for a seed",
     [](FilterOptions& o, const std::string& t) {
       o.seed = static_cast<uint64_t>(integerIn(t, 0, 1LL << 62));
     },
     [](const FilterOptions& o) { return std::to_string(o.seed); }},
};

}  // namespace

std::string shortestText(double value) {
  std::ostringstream text;
  for (int digits = 15;; ++digits) {
    text.str("");
    text << std::setprecision(digits) << value;
    if (digits == 17 || std::stod(text.str()) == value) return text.str();
  }
}

const std::vector<FilterOptionKey>& filterOptionKeys() { return kKeys; }

void setFilterOption(FilterOptions& options, const std::string& key, const std::string& text) {
  for (const FilterOptionKey& entry : kKeys) {
    if (key != entry.key) continue;
    try {
      entry.set(options, text);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(key + ": " + e.what());
    }
    return;
  }
  throw std::invalid_argument(key + ": not a filter option");
}

void validateFilterOptions(const FilterOptions& options) {
  FilterOptions copy = options;
  for (const FilterOptionKey& entry : kKeys) setFilterOption(copy, entry.key, entry.get(options));
  if (options.refine.swap.knees_only && !options.refine.swap.enabled)
    throw std::invalid_argument("refine_swap: knees only, but the swap is off");
  if (options.likelihood.points_per_circle < 3)
    throw std::invalid_argument("points_per_circle: expected at least 3");
}

FilterOptions humanFilterDefaults() {
  FilterOptions options;
  options.lookahead = FilterOptions::Lookahead::kBody;
  options.injection.redraw = InjectionOptions::Redraw::kSegment;
  options.injection.share = 0.05;
  options.refine.share = 0.4;
  options.refine.hold = true;
  options.refine.plant = true;
  options.refine.restart_share = 0.14;
  options.refine.facing_prior = 16;
  options.refine.uncross = 10;
  return options;
}

}  // namespace mocap
