// The travel prior (FilterOptions::travel_prior): a person who walks or runs faces the way they go.
// Two cameras barely tell a body's front from its back, so a walking track can turn round and stay
// turned; the root's recent positions say which way it goes, whichever way the track faces.
#pragma once

#include <deque>

#include <Eigen/Core>

#include "tracker/model/body_model.h"

namespace mocap {

class TravelPrior {
 public:
  // Estimates recorded before the prior speaks: 8 frames, a third of a second at 25 Hz.
  static constexpr int kHistory = 8;

  // Borrows `model`. Off (no cost, ever) at weight 0 or for a model without `forward`.
  TravelPrior(const BodyModel& model, double weight);

  // A new track: forget where the body went.
  void clear();
  // The frame's estimate, the newest of the history.
  void record(const Eigen::VectorXd& q);
  // W s (1 - cos a) / 2: a the angle on the ground between where `q`'s root faces and where the
  // root went over the history, s from 0 at 15 % of the root's speed limit to 1 at 30 % (the
  // human's: 0.4 to 0.75 m/s, below a slow walk). 0 while the body stands or shuffles, or before
  // the history is full.
  double cost(const Eigen::VectorXd& q) const;
  bool active() const { return strength_ > 0; }

 private:
  const BodyModel& model_;
  double weight_;
  double speed_limit_ = 0;  // the root's fastest translation, per frame
  std::deque<Eigen::Vector2d> positions_;
  Eigen::Vector2d direction_ = Eigen::Vector2d::Zero();
  double strength_ = 0;
};

}  // namespace mocap
