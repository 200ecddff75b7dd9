// Coordinate search of a pose.
#include "tracker/search/pose_search.h"

#include <algorithm>

namespace mocap {

int coordinateSearch(const BodyModel& model,
                     const std::function<double(const Eigen::VectorXd&)>& score,
                     const SearchDofs& search, int budget, Eigen::VectorXd& q, double& value) {
  std::vector<double> step = search.first_step;
  int spent = 0;
  bool moving = true;
  while (spent < budget && moving) {
    moving = false;
    for (std::size_t i = 0; i < search.dofs.size() && spent < budget; ++i) {
      if (step[i] < search.finest[i]) continue;
      moving = true;
      bool improved = false;
      for (double sign : {1.0, -1.0}) {
        if (spent >= budget) break;
        const int d = search.dofs[i];
        const Dof& dof = model.dofs[d];
        Eigen::VectorXd tried = q;
        tried[d] = std::clamp(q[d] + sign * step[i], dof.min, dof.max);
        ++spent;
        const double v = score(tried);
        if (v > value) {
          q = std::move(tried);
          value = v;
          step[i] *= 1.5;
          improved = true;
          break;
        }
      }
      if (!improved) step[i] *= 0.5;
    }
  }
  return spent;
}

}  // namespace mocap
