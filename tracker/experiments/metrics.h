// Tracking error measures of the experiments.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace mocap {

// Point trajectories: trajectory[frame][point].
using PointTrack = std::vector<std::vector<Eigen::Vector3d>>;

// The paper's relative error (§7): per point, the distance between tracked and true positions
// divided by the point's movement amplitude (the largest distance between two of its true
// positions), averaged over time. Points that do not move (amplitude below `min_amplitude`) get
// a negative value and are left out of the means.
std::vector<double> relativeErrorPerPoint(const PointTrack& truth, const PointTrack& tracked,
                                          double min_amplitude = 1e-4);

// Mean Euclidean distance per point over time (metres).
std::vector<double> meanErrorPerPoint(const PointTrack& truth, const PointTrack& tracked);

}  // namespace mocap
