// Local search of a pose on any score (in practice the full-body likelihood): what acquisition
// fits a placed stance with, and what fitting the body's size refines each tracked pose with.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "tracker/model/body_model.h"

namespace mocap {

// The DOFs a search moves, each with its first step and the finest step worth trying (radians or
// metres).
struct SearchDofs {
  std::vector<int> dofs;
  std::vector<double> first_step;
  std::vector<double> finest;
  void add(int dof, double first, double finest_step) {
    dofs.push_back(dof);
    first_step.push_back(first);
    finest.push_back(finest_step);
  }
};

// Coordinate search from `q` (scoring `value`): each DOF in turn is tried a step up, then down,
// within its limits; a step that improves is kept and grows by half, one that fails both ways
// halves, until every step is finer than its `finest` or `budget` scores are spent. Updates q and
// value; returns the scores spent.
int coordinateSearch(const BodyModel& model,
                     const std::function<double(const Eigen::VectorXd&)>& score,
                     const SearchDofs& search, int budget, Eigen::VectorXd& q, double& value);

}  // namespace mocap
