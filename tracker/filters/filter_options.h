// The filters' options, nested per filter part and per refinement move, and the one table of their
// keys: the daemon's `tracker:` YAML keys, the settings a recorded session stores and the
// experiments' flags (--key-name) all read and write the options through filterOptionKeys(), and
// validateFilterOptions() is the one place they are checked.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tracker/likelihood/likelihood.h"

namespace mocap {

// Static particle injection (paper §8.3): the share of a layer's candidates drawn from the static
// distribution, and what such a candidate redraws over the whole range. kDof is the paper: the
// layer's DOF. kSegment: at a segment's first DOF layer, all its joint angles at once (and the
// layer's DOF elsewhere): a limb lost inside the trunk's silhouette scores no better one DOF away,
// and only comes back when its angles land near the truth together.
struct InjectionOptions {
  enum class Redraw { kDof, kSegment };
  double share = 0.02;
  Redraw redraw = Redraw::kDof;
};

// The refinement's leg swap: each frame, after the restarts and before the pattern search, the two
// legs (each of the model's two `feet` with its parent and grandparent) exchange their joint
// angles, and the exchanged pose is searched locally on the legs' angles (up to 2 poses per leg
// angle). It replaces the pose if it scores `margin` silhouette pixels better (that many times the
// likelihood's beta). Two silhouettes often fit both ways round (which leg is in front), no step of
// one leg gets from one to the other, and the margin keeps the tracker from flipping between the
// two on a small difference.
struct SwapOptions {
  bool enabled = false;
  // Exchange only the knees' angles (the feet's parents), then search the legs as above. A kneel
  // tracked with the wrong knee bent is this, with the hips right.
  bool knees_only = false;
  double margin = 500;
};

// The full-body refinement after the layers: a pattern search over every DOF on the full-body
// likelihood, one evaluation per pose tried, starting from the best particle, and its moves. The
// layers place each DOF with the segments not yet placed standing where they were a frame ago; this
// corrects what that greedy order got wrong.
struct RefineOptions {
  // Share of the budget spent on the refinement; 0: off (the paper).
  double share = 0;
  // At most this many of its evaluations per frame (0: all the layers leave; 1 counts as 2, the
  // starting pose and one trial), for a step that must fit a time budget; the rest goes unspent.
  int max_evaluations = 0;
  // A rotation DOF whose segment has ball-joint children (three rotations about distinct axes)
  // that fails both ways is tried once more both ways with those children's angles re-solved so
  // they keep their world orientation. Turning the pelvis then leaves the legs and the trunk
  // pointing where they did: a body tracked with its pelvis turned the wrong way has its limbs
  // twisted to fit, and no single joint angle can undo that.
  bool hold = false;
  // A step of the pelvis's position that fails both ways is tried once more both ways with the hips
  // and knees of the model's `feet` re-solved so the feet stay where they are. Squatting, kneeling
  // or shifting weight moves the pelvis over planted feet; a pelvis step alone swings the feet
  // through the floor, and no single leg angle follows it.
  bool plant = false;
  SwapOptions swap;
  // The share of the refinement's evaluations that, before the pattern search, restart one limb
  // (the next in turn each frame: legs, arms, chest, head) from random draws of its root segment's
  // angles over their whole range (a quarter of that share); the best draw is searched locally on
  // all the limb's angles (up to 3 poses per draw) and kept if it beats the pose. A limb settled on
  // the wrong part of the silhouette (one leg on the other's) scores better than any pose a few
  // steps away, so no local step leaves it. 0: off.
  double restart_share = 0;
  // For a model with `feet`: each frame, after the restarts and swaps, the silhouette the pose
  // leaves unexplained is chased (tracker/likelihood/unexplained.h). In each camera the largest
  // blob's centroid gives a ray, and each leg's knee, then ankle, is moved by its hip and knee
  // angles to the ray's point nearest it if that point is below the hip (world z up), one
  // evaluation each; the best is searched locally on its leg's angles but the facing twists (up to
  // 2 poses per angle) and kept if it beats the pose. A leg lost inside the trunk explains nothing
  // new and costs nothing, so no local step pulls it out; the blob it left says where it went.
  bool unexplained = false;
  // The weight of a prior that the pelvis faces where the legs do, for a model that names its legs'
  // twists (BodyModel::facing_twists): the refinement scores a pose by its log-likelihood minus
  // W (c / s)^2, c the mean of those twists (each signed by its axis against the first's) and s the
  // first's speed limit. Two silhouettes barely show which way the pelvis faces, and a pelvis
  // turned the wrong way scores as well with the hips twisted back, so without it the heading
  // drifts by tens of degrees over a walk. Unlike a prior on the heading's change, it does not hold
  // back a subject who turns. 0: off.
  double facing_prior = 0;
  // For a model with two `feet`: the weight of a cost on the feet crossed over in the body's own
  // frame, and each frame, if they cross at all, a move that gives each leg the other's foot. Two
  // views of a stride fit nearly as well with the legs' labels exchanged and the legs crossed to
  // reach the same feet; no step of one leg gets from there to the uncrossed twin, and without the
  // cost the likelihood barely tells them apart. The refinement scores a pose by its
  // log-likelihood less W (max(0, c - 0.15) / 0.1)^2, c how far the feet have passed each other
  // along the line through the hips, in metres (tracker/filters/refine/uncross.h); a tracker that
  // finds the subject charges it to every pose it scores too (AcquireOptions::uncross). 0: off.
  double uncross = 0;
};

struct FilterOptions {
  // Particle evaluations per frame, as the paper counts them: one per candidate per layer for the
  // factored filter (15 layers x 25 = 375 for the hand), one per full-body particle otherwise.
  int evaluations_per_frame = 375;
  int keep = 5;                // factored: K best candidates kept per layer
  int samples = 0;             // factored: S samples per interval; 0 = derived from the budget
  InjectionOptions injection;  // factored
  // factored: what a layer ranks its candidates by. kNone is the paper: the layer's own segment
  // against the silhouette minus what earlier segments explain. Greedy, it lets a segment slide
  // over silhouette that belongs to segments observed later (a big root or trunk steals the limbs'
  // pixels). kBody ranks every layer by the whole body: what is already placed, the candidate's
  // subtree, and every other segment not yet placed at its previous relative pose (so one leg does
  // not take the other leg's pixels). Either way a particle's weight keeps only the segment's own
  // factor, so the product of factors along the chain stays the paper's likelihood.
  enum class Lookahead { kNone, kBody };
  Lookahead lookahead = Lookahead::kNone;
  RefineOptions refine;      // factored
  int annealing_layers = 5;  // annealed: number of annealing layers per frame
  uint64_t seed = 1;
  LikelihoodParams likelihood;
};

// One key of the table. `key` is the YAML key under `tracker:` and the key a session stores; the
// experiments take it as the flag --key with '-' for '_'.
struct FilterOptionKey {
  const char* key;
  const char* values;  // what the key takes, for help and errors ("0-0.99", "none|body", ...)
  const char* help;
  // Sets the option from text; throws std::invalid_argument "expected <values>, got '<text>'".
  void (*set)(FilterOptions& options, const std::string& text);
  // The option as text that set() reads back to the same value.
  std::string (*get)(const FilterOptions& options);
};

const std::vector<FilterOptionKey>& filterOptionKeys();

// The shortest text that reads back to the same double: how the table writes a number.
std::string shortestText(double value);

// Sets the option `key` from `text`; throws std::invalid_argument "<key>: expected ..., got '...'"
// for an unknown key or a bad value.
void setFilterOption(FilterOptions& options, const std::string& key, const std::string& text);

// Every check of the options together, with the key of the first bad one: throws
// std::invalid_argument "<key>: <reason>". The filters call it before they start.
void validateFilterOptions(const FilterOptions& options);

// The factored filter's options for the human body, chosen on the walk (seeds 1-3): look-ahead
// over the whole body, 5 % of the candidates injected with a segment's angles at once, and 40 % of
// the budget on the full-body refinement, which also turns segments with their ball-joint children
// held and restarts one limb per frame with 14 % of the refinement (32 random draws at 2000
// evaluations; walk seeds 1-6), and scores poses with the facing prior (weight 16; walk and hop
// seeds 7-24, checked on 61-96) and the crossed feet's cost with its move (weight 10; the product
// path's development subjects). The paper has no look-ahead, injects one DOF into 2 % and does not
// refine. See docs/human.md.
FilterOptions humanFilterDefaults();
// The paper's budget for the full 31-DOF body (§8), the experiments' and the daemon's default.
inline constexpr int kHumanEvaluations = 2000;

}  // namespace mocap
