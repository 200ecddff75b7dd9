// Joint-space motions: sequences of DOF vectors, generated from a seed or read from CSV (a header
// of DOF names, then one row of radians/metres per frame).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tracker/model/body_model.h"

namespace mocap {

using Motion = std::vector<Eigen::VectorXd>;  // one DOF vector per frame, model DOF order

// A smooth motion in which every DOF keeps moving over most of its range, at times near its speed
// limit: each DOF chases random targets with a speed cap drawn per target and bounded
// acceleration, so its velocity is continuous and never exceeds max_speed.
Motion generateMotion(const BodyModel& model, int frames, uint64_t seed);

// Reads a CSV motion. Every DOF of the model must have a column (any order); throws
// std::runtime_error naming the file, line and column for an unknown or missing column, a row with
// the wrong number of values, a non-numeric value or a value outside the DOF's limits.
Motion loadMotionCsv(const std::string& path, const BodyModel& model);
void saveMotionCsv(const std::string& path, const BodyModel& model, const Motion& motion);

}  // namespace mocap
