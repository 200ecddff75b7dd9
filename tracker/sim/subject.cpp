// Simulated subjects: proportions from a seed, retargeting onto the driver's joints, and the
// surface as ellipsoids, round cones and frusta (see subject.h).
#include "tracker/sim/subject.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include "tracker/model/kinematics.h"

namespace mocap {

const std::array<const char*, kSubjectJointCount> kSubjectJointNames = {
    "pelvis", "neck",       "head_top", "r_hip",   "r_knee",     "r_ankle", "r_toe",
    "l_hip",  "l_knee",     "l_ankle",  "l_toe",   "r_shoulder", "r_elbow", "r_wrist",
    "r_hand", "l_shoulder", "l_elbow",  "l_wrist", "l_hand"};

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

// The joint each joint hangs from (parents precede children in SubjectJoint order).
constexpr std::array<int, kSubjectJointCount> kParent = {
    -1,      kPelvis, kNeck,      kPelvis, kRHip,   kRKnee, kRAnkle,    kPelvis, kLHip,  kLKnee,
    kLAnkle, kNeck,   kRShoulder, kRElbow, kRWrist, kNeck,  kLShoulder, kLElbow, kLWrist};

// Floor to ankle joint, standing, as a fraction of the height.
constexpr double kAnkleHeight = 0.041;

uint64_t splitmix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// The hip joints below the pelvis joint and the shoulder joints below the neck joint, as fractions
// of the height: the means of the CMU skeletons the truth is mapped from (the pelvis joint is their
// Hips, the neck their Neck). Their Hips also sits 3 to 7 cm behind the hip joints; the subject's
// is straight above them, where a body model's pelvis point is.
constexpr double kHipDrop = 0.057, kShoulderDrop = 0.015;

// The bone to each joint from its parent as a fraction of the height (an average adult's, joint
// centre to joint centre), times the subject's factors. The hips' and shoulders' are their
// lateral offsets (half the joint spacing); the rest of those offsets is below.
std::array<double, kSubjectJointCount> boneFractions(const SubjectParams& p) {
  std::array<double, kSubjectJointCount> f{};
  f[kNeck] = (0.30 - kHipDrop) * p.trunk;
  f[kHeadTop] = 0.168;
  for (int side : {0, 1}) {
    const int hip = side ? kLHip : kRHip, shoulder = side ? kLShoulder : kRShoulder;
    f[hip] = 0.0525 * p.hip_width;
    f[hip + 1] = 0.245 * p.thigh;
    f[hip + 2] = 0.246 * p.shin;
    f[hip + 3] = 0.108;
    f[shoulder] = 0.11 * p.shoulder_width;
    f[shoulder + 1] = 0.172 * p.upper_arm;
    f[shoulder + 2] = 0.152 * p.forearm;
    f[shoulder + 3] = 0.06 * p.forearm;
  }
  return f;
}

Vector3d unitOr(const Vector3d& v, const Vector3d& fallback) {
  const double n = v.norm();
  return n > 1e-9 ? Vector3d(v / n) : fallback;
}

// `v` made perpendicular to the unit `axis` and normalised (a perpendicular of `axis` if parallel).
Vector3d perpendicular(const Vector3d& v, const Vector3d& axis) {
  const Vector3d p = v - v.dot(axis) * axis;
  if (p.norm() > 1e-6) return p.normalized();
  return axis.unitOrthogonal();
}

// Columns x, y, z: an orthonormal right-handed frame with z along `axis`, x toward `right`.
Matrix3d frameAlong(const Vector3d& axis, const Vector3d& right) {
  Matrix3d m;
  m.col(2) = axis;
  m.col(0) = perpendicular(right, axis);
  m.col(1) = axis.cross(m.col(0));
  return m;
}

SubjectPrimitive ellipsoid(const Vector3d& centre, const Matrix3d& frame, const Vector3d& radii,
                           SubjectMaterial material) {
  SubjectPrimitive p;
  p.kind = SubjectPrimitive::Kind::kEllipsoid;
  p.material = material;
  p.origin = centre;
  p.linear = frame * radii.asDiagonal();
  return p;
}

// A round cone (or, with `flat`, a frustum) from `a` to `b`; its cross-section `depth` times as
// deep (frame y, toward right x axis) as wide.
SubjectPrimitive swept(const Vector3d& a, double ra, const Vector3d& b, double rb,
                       SubjectMaterial material, const Vector3d& right = Vector3d::UnitX(),
                       double width = 1, double depth = 1, bool flat = false) {
  SubjectPrimitive p;
  p.kind = flat ? SubjectPrimitive::Kind::kFrustum : SubjectPrimitive::Kind::kRoundCone;
  p.material = material;
  const Vector3d axis = unitOr(b - a, Vector3d::UnitZ());
  p.origin = a;
  p.linear = frameAlong(axis, right) * Vector3d(width, depth, 1).asDiagonal();
  p.length = (b - a).norm();
  p.radius0 = ra;
  p.radius1 = rb;
  return p;
}

// The trunk's frame at the hips (pelvis) and at the shoulders (chest).
struct TrunkFrames {
  Vector3d up, right_p, fwd_p, right_c, fwd_c, right_m, fwd_m;
  double length = 0, hip_half = 0, shoulder_half = 0;
};

TrunkFrames trunkFrames(const SubjectJoints& j) {
  TrunkFrames t;
  t.up = unitOr(j[kNeck] - j[kPelvis], Vector3d::UnitZ());
  t.right_p = perpendicular(j[kRHip] - j[kLHip], t.up);
  t.right_c = perpendicular(j[kRShoulder] - j[kLShoulder], t.up);
  t.right_m = perpendicular(t.right_p + t.right_c, t.up);
  t.fwd_p = t.up.cross(t.right_p);
  t.fwd_c = t.up.cross(t.right_c);
  t.fwd_m = t.up.cross(t.right_m);
  t.length = (j[kNeck] - j[kPelvis]).norm();
  t.hip_half = 0.5 * (j[kRHip] - j[kLHip]).norm();
  t.shoulder_half = 0.5 * (j[kRShoulder] - j[kLShoulder]).norm();
  return t;
}

// A frame that turns with the driver's pelvis (origin kPelvis, joints kRHip and kLHip) or its
// chest (kNeck, kRShoulder, kLShoulder): columns right, forward and up, from the three joints,
// which turn together on any skeleton or body model. Where they are in line (a body whose hips
// are level with its pelvis joint) the up axis is the spine's instead.
Matrix3d girdleFrame(const SubjectJoints& j, int origin, int right, int left) {
  Matrix3d m;
  m.col(0) = unitOr(j[right] - j[left], Vector3d::UnitX());
  const Vector3d centre = 0.5 * (j[right] + j[left]) - j[origin];
  const Vector3d across = centre - centre.dot(m.col(0)) * m.col(0);
  const Vector3d up = across.norm() > 0.01 ? Vector3d(-across) : Vector3d(j[kNeck] - j[kPelvis]);
  m.col(2) = perpendicular(up, m.col(0));
  m.col(1) = m.col(2).cross(m.col(0));
  return m;
}

}  // namespace

SubjectParams drawSubjectParams(uint64_t seed) {
  std::mt19937_64 rng(splitmix64(seed ^ 0x5ab1ec7ull));
  auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  auto pick = [&](std::size_t n) {
    return static_cast<std::size_t>(std::uniform_int_distribution<std::size_t>(0, n - 1)(rng));
  };
  SubjectParams p;
  p.height = uniform(1.50, 1.95);
  p.girth = uniform(0.85, 1.35);
  p.thigh = uniform(0.9, 1.1);
  p.shin = uniform(0.9, 1.1);
  p.upper_arm = uniform(0.9, 1.1);
  p.forearm = uniform(0.9, 1.1);
  p.trunk = uniform(0.9, 1.1);
  p.shoulder_width = uniform(0.9, 1.1);
  p.hip_width = uniform(0.9, 1.1);
  Clothing& c = p.clothing;
  const double lower = uniform(0, 1);
  c.lower = lower < 0.4   ? LowerGarment::kTrousers
            : lower < 0.6 ? LowerGarment::kLooseTrousers
            : lower < 0.8 ? LowerGarment::kSkirt
                          : LowerGarment::kDress;
  c.coat = uniform(0, 1) < 0.25;
  c.long_hair = uniform(0, 1) < 0.35;
  c.shoes = uniform(0, 1) < 0.9;
  static const cv::Vec3b skins[] = {{185, 205, 240}, {150, 180, 225}, {110, 150, 200},
                                    {80, 115, 165},  {50, 75, 115},   {40, 55, 85}};
  static const cv::Vec3b hairs[] = {{20, 25, 30},   {30, 45, 70},    {40, 80, 140},
                                    {90, 150, 200}, {150, 150, 150}, {30, 30, 120}};
  static const cv::Vec3b tops[] = {{170, 90, 60}, {60, 60, 180},  {235, 235, 235}, {40, 40, 40},
                                   {80, 150, 80}, {60, 170, 220}, {150, 60, 150},  {120, 120, 120}};
  static const cv::Vec3b bottoms[] = {{110, 70, 40}, {40, 40, 40},  {150, 160, 170},
                                      {60, 90, 130}, {30, 30, 110}, {200, 200, 200}};
  static const cv::Vec3b coats[] = {{40, 70, 110}, {30, 30, 30},  {100, 110, 120},
                                    {60, 80, 60},  {100, 45, 30}, {140, 170, 190}};
  static const cv::Vec3b shoes[] = {{20, 20, 20}, {230, 230, 230}, {30, 50, 90}, {120, 120, 120}};
  c.skin = skins[pick(std::size(skins))];
  c.hair = hairs[pick(std::size(hairs))];
  c.top = tops[pick(std::size(tops))];
  c.bottom = bottoms[pick(std::size(bottoms))];
  c.coat_colour = coats[pick(std::size(coats))];
  c.shoe_colour = shoes[pick(std::size(shoes))];
  return p;
}

int subjectJointParent(int joint) { return kParent[joint]; }

SubjectJoints subjectJointsFromPoints(const BodyModel& model,
                                      const std::vector<Eigen::Vector3d>& points) {
  SubjectJoints joints;
  for (int j = 0; j < kSubjectJointCount; ++j) {
    const int p = model.pointIndex(kSubjectJointNames[j]);
    if (p < 0 || p >= static_cast<int>(points.size()))
      throw std::invalid_argument("body model '" + model.name + "' has no point '" +
                                  kSubjectJointNames[j] + "' to pose a subject by");
    joints[j] = points[p];
  }
  return joints;
}

SubjectJoints subjectJointsAt(const BodyModel& model, const Eigen::VectorXd& q) {
  KinematicsData kin(model);
  forwardKinematics(model, kin, q);
  return subjectJointsFromPoints(model, pointPositions(model, kin));
}

Eigen::Matrix3d pelvisTurnAt(const BodyModel& model, const KinematicsData& kinematics) {
  const int pelvis = model.pointIndex(kSubjectJointNames[kPelvis]);
  if (pelvis < 0)
    throw std::invalid_argument("body model '" + model.name + "' has no point 'pelvis'");
  return kinematics.world[model.points[pelvis].segment].rotation();
}

std::vector<Eigen::Vector3d> modelPointsFromJoints(const BodyModel& model,
                                                   const SubjectJoints& joints) {
  std::vector<Eigen::Vector3d> points(model.points.size(), Vector3d::Zero());
  for (int j = 0; j < kSubjectJointCount; ++j) {
    const int p = model.pointIndex(kSubjectJointNames[j]);
    if (p >= 0) points[p] = joints[j];
  }
  return points;
}

Subject::Subject(const SubjectParams& params, const SubjectJoints& driver_rest) : params_(params) {
  const std::array<double, kSubjectJointCount> fraction = boneFractions(params);
  for (int j = 0; j < kSubjectJointCount; ++j) bone_length_[j] = fraction[j] * params.height;
  driver_trunk_ = std::max(1e-6, (driver_rest[kNeck] - driver_rest[kPelvis]).norm());
  // The subject's own hips and shoulders, standing upright where the driver stands at rest.
  const Vector3d up = Vector3d::UnitZ();
  const Vector3d right_p = perpendicular(driver_rest[kRHip] - driver_rest[kLHip], up);
  const Vector3d right_c = perpendicular(driver_rest[kRShoulder] - driver_rest[kLShoulder], up);
  rest_pelvis_frame_ = girdleFrame(driver_rest, kPelvis, kRHip, kLHip);
  const Matrix3d chest_frame = girdleFrame(driver_rest, kNeck, kRShoulder, kLShoulder);
  for (int side : {1, -1}) {
    const Vector3d hip = side * bone_length_[kRHip] * right_p - params.height * kHipDrop * up;
    const Vector3d shoulder =
        side * bone_length_[kRShoulder] * right_c - params.height * kShoulderDrop * up;
    girdle_offset_[side > 0 ? kRHip : kLHip] = rest_pelvis_frame_.transpose() * hip;
    girdle_offset_[side > 0 ? kRShoulder : kLShoulder] = chest_frame.transpose() * shoulder;
  }
  // Built once at the nominal lengths, then scaled as a whole so the crown is at the height.
  for (int pass = 0; pass < 2; ++pass) {
    pelvis_height_ratio_ = 1;
    SubjectJoints shape = retarget(driver_rest);
    const double ankle_height = kAnkleHeight * params.height;
    const double ankle = std::min(shape[kRAnkle].z(), shape[kLAnkle].z()) - shape[kPelvis].z();
    const double pelvis = ankle_height - ankle;
    const double crown = pelvis + shape[kHeadTop].z() - shape[kPelvis].z();
    if (pass == 0) {
      const double scale = (params.height - ankle_height) / (crown - ankle_height);
      for (double& length : bone_length_) length *= scale;
      for (Vector3d& offset : girdle_offset_) offset *= scale;
      continue;
    }
    pelvis_height_ratio_ = driver_rest[kPelvis].z() > 1e-6 ? pelvis / driver_rest[kPelvis].z() : 1;
  }
  rest_ = retarget(driver_rest);
}

SubjectJoints Subject::retarget(const SubjectJoints& driver, const Matrix3d* pelvis_turn) const {
  SubjectJoints out;
  out[kPelvis] = driver[kPelvis];
  out[kPelvis].z() *= pelvis_height_ratio_;
  const Matrix3d pelvis = pelvis_turn ? Matrix3d(*pelvis_turn * rest_pelvis_frame_)
                                      : girdleFrame(driver, kPelvis, kRHip, kLHip);
  const Matrix3d chest = girdleFrame(driver, kNeck, kRShoulder, kLShoulder);
  for (int j = 1; j < kSubjectJointCount; ++j) {
    const int parent = kParent[j];
    if (j == kRHip || j == kLHip)
      out[j] = out[parent] + pelvis * girdle_offset_[j];
    else if (j == kRShoulder || j == kLShoulder)
      out[j] = out[parent] + chest * girdle_offset_[j];
    else if (j == kNeck)  // the spine bends as the driver's does, shortening as it bends
      out[j] = out[parent] + bone_length_[j] / driver_trunk_ * (driver[j] - driver[parent]);
    else
      out[j] =
          out[parent] + bone_length_[j] * unitOr(driver[j] - driver[parent], Vector3d::UnitZ());
  }
  return out;
}

void Subject::pose(const SubjectJoints& driver, PosedSubject& out,
                   const Matrix3d* pelvis_turn) const {
  out.joints = retarget(driver, pelvis_turn);
  out.clothing = &params_.clothing;
  out.primitives.clear();
  addTrunkAndHead(out.joints, out);
  addLimbs(out.joints, out);
  addGarments(out.joints, out);
}

void Subject::pose(const BodyModel& model, const KinematicsData& kinematics,
                   PosedSubject& out) const {
  const Matrix3d pelvis_turn = pelvisTurnAt(model, kinematics);
  pose(subjectJointsFromPoints(model, pointPositions(model, kinematics)), out, &pelvis_turn);
}

void Subject::addTrunkAndHead(const SubjectJoints& j, PosedSubject& out) const {
  const double r = params_.height / 1.75, g = params_.girth;
  const Clothing& c = params_.clothing;
  const TrunkFrames t = trunkFrames(j);
  const double coat = c.coat ? 0.03 * r : 0;
  const bool dress = c.lower == LowerGarment::kDress;
  const SubjectMaterial top = c.coat  ? SubjectMaterial::kCoat
                              : dress ? SubjectMaterial::kBottom
                                      : SubjectMaterial::kTop;
  const SubjectMaterial hips = c.coat ? SubjectMaterial::kCoat : SubjectMaterial::kBottom;
  Matrix3d pelvis_frame, mid_frame, chest_frame;
  pelvis_frame << t.right_p, t.fwd_p, t.up;
  mid_frame << t.right_m, t.fwd_m, t.up;
  chest_frame << t.right_c, t.fwd_c, t.up;
  auto& p = out.primitives;
  p.push_back(ellipsoid(j[kPelvis] + 0.03 * r * t.up - 0.01 * r * t.fwd_p, pelvis_frame,
                        {t.hip_half + 0.085 * r * std::pow(g, 1.1) + coat,
                         0.10 * r * std::pow(g, 1.3) + coat, 0.15 * r},
                        hips));
  p.push_back(ellipsoid(
      j[kPelvis] + 0.40 * t.length * t.up + 0.03 * r * (g - 1) * t.fwd_m, mid_frame,
      {0.135 * r * std::pow(g, 1.3) + coat, 0.095 * r * std::pow(g, 1.7) + coat, 0.26 * t.length},
      top));
  const double chest_depth = 0.10 * r * std::pow(g, 1.2) + coat;
  p.push_back(ellipsoid(j[kPelvis] + 0.72 * t.length * t.up, chest_frame,
                        {0.8 * t.shoulder_half + 0.02 * r * g + coat, chest_depth, 0.30 * t.length},
                        top));
  out.chest = j[kPelvis] + 0.72 * t.length * t.up + chest_depth * t.fwd_c;
  // Shoulder slope: from the base of the neck to each shoulder.
  const Vector3d neck_base = j[kNeck] - 0.04 * r * t.up;
  for (int shoulder : {kRShoulder, kLShoulder})
    p.push_back(swept(neck_base, 0.06 * r * g + coat, j[shoulder],
                      0.05 * r * g + (c.coat ? 0.018 * r : 0), top));
  // Head: the crown just above the head-top joint; a hair cap over the back, top and sides.
  const Vector3d up_h = unitOr(j[kHeadTop] - j[kNeck], t.up);
  Matrix3d head_frame;
  head_frame.col(2) = up_h;
  head_frame.col(0) = perpendicular(t.right_c, up_h);
  head_frame.col(1) = up_h.cross(head_frame.col(0));
  const Vector3d head = j[kHeadTop] - 0.11 * r * up_h + 0.01 * r * head_frame.col(1);
  const std::size_t first_head_piece = p.size();
  p.push_back(
      swept(neck_base, 0.052 * r * std::pow(g, 0.7), head, 0.045 * r, SubjectMaterial::kSkin));
  p.push_back(
      ellipsoid(head, head_frame, Vector3d(0.075, 0.095, 0.115) * r, SubjectMaterial::kSkin));
  p.push_back(ellipsoid(head - 0.015 * r * head_frame.col(1) + 0.012 * r * up_h, head_frame,
                        Vector3d(0.081, 0.092, 0.112) * r, SubjectMaterial::kHair));
  if (c.long_hair) {
    const Vector3d top_of_hair = head - 0.035 * r * head_frame.col(1) + 0.01 * r * up_h;
    const Vector3d ends = j[kNeck] - 0.13 * r * t.up - (0.07 * r + chest_depth - 0.1 * r) * t.fwd_c;
    p.push_back(swept(top_of_hair, 0.075 * r, ends, 0.065 * r, SubjectMaterial::kHair, t.right_c,
                      1.15, 0.55));
  }
  for (std::size_t i = first_head_piece; i < p.size(); ++i) p[i].bone = kHeadTop;
}

void Subject::addLimbs(const SubjectJoints& j, PosedSubject& out) const {
  const double r = params_.height / 1.75, g = params_.girth;
  const Clothing& c = params_.clothing;
  const TrunkFrames t = trunkFrames(j);
  auto& p = out.primitives;
  const double sleeve = c.coat ? 0.018 * r : 0;
  const SubjectMaterial upper = c.coat                            ? SubjectMaterial::kCoat
                                : c.lower == LowerGarment::kDress ? SubjectMaterial::kSkin
                                                                  : SubjectMaterial::kTop;
  const SubjectMaterial lower = c.coat ? SubjectMaterial::kCoat : SubjectMaterial::kSkin;
  for (int side : {0, 1}) {
    const int sh = side ? kLShoulder : kRShoulder;
    const Vector3d &shoulder = j[sh], &elbow = j[sh + 1], &wrist = j[sh + 2], &hand = j[sh + 3];
    p.push_back(swept(shoulder, 0.047 * r * g + sleeve, elbow, 0.037 * r * g + sleeve, upper));
    p.push_back(swept(elbow, 0.037 * r * g + sleeve, wrist,
                      0.026 * r * std::pow(g, 0.7) + 0.8 * sleeve, lower));
    // The hand's rounded end just beyond the hand point (the fingertips).
    p.push_back(swept(wrist, 0.024 * r, hand - 0.01 * r * unitOr(hand - wrist, -t.up), 0.022 * r,
                      SubjectMaterial::kSkin));
    for (int piece = 0; piece < 3; ++piece) p[p.size() - 3 + piece].bone = sh + 1 + piece;
  }
  const bool loose = c.lower == LowerGarment::kLooseTrousers;
  const bool bare = c.lower == LowerGarment::kSkirt || c.lower == LowerGarment::kDress;
  const SubjectMaterial leg = bare ? SubjectMaterial::kSkin : SubjectMaterial::kBottom;
  const double cloth = bare ? 0 : 0.008 * r;
  for (int side : {0, 1}) {
    const int hp = side ? kLHip : kRHip;
    const Vector3d &hip = j[hp], &knee = j[hp + 1], &ankle = j[hp + 2], &toe = j[hp + 3];
    const Vector3d leg_up = unitOr(knee - ankle, t.up);
    const double thigh0 = 0.082 * r * std::pow(g, 1.2) + cloth;
    const std::size_t thigh = p.size();
    if (loose) {
      p.push_back(swept(hip, thigh0 + 0.03 * r, knee, 0.085 * r * g, leg));
      p.push_back(swept(knee, 0.085 * r * g, ankle - 0.02 * r * leg_up, 0.08 * r * g, leg));
    } else {
      p.push_back(swept(hip, thigh0, knee, 0.05 * r * g + cloth, leg));
      p.push_back(
          swept(knee, 0.048 * r * g + cloth, ankle, 0.032 * r * std::pow(g, 0.6) + cloth, leg));
      Matrix3d calf_frame = frameAlong(-leg_up, t.right_p);
      const Vector3d calf = knee + 0.3 * (ankle - knee) - 0.012 * r * calf_frame.col(1);
      p.push_back(ellipsoid(calf, calf_frame, Vector3d(0.05 * g, 0.05 * g, 0.11) * r, leg));
    }
    // Foot from heel to toes; a shoe is larger all round with its sole at the same level.
    const Vector3d ahead = perpendicular(toe - ankle, leg_up);
    const double shoe = c.shoes ? 0.008 * r : 0;
    const Vector3d heel = ankle - (0.035 * r - shoe) * leg_up - (0.035 * r + shoe) * ahead;
    const Vector3d tip = toe + (0.012 * r + shoe) * leg_up + 1.5 * shoe * ahead;
    p.push_back(swept(heel, 0.035 * r + shoe, tip, 0.028 * r + shoe,
                      c.shoes ? SubjectMaterial::kShoe : SubjectMaterial::kSkin));
    p[thigh].bone = hp + 1;
    for (std::size_t i = thigh + 1; i + 1 < p.size(); ++i) p[i].bone = hp + 2;  // shin, calf
    p.back().bone = hp + 3;
  }
}

void Subject::addGarments(const SubjectJoints& j, PosedSubject& out) const {
  const double r = params_.height / 1.75, g = params_.girth;
  const Clothing& c = params_.clothing;
  const TrunkFrames t = trunkFrames(j);
  auto& p = out.primitives;
  const Vector3d knees = 0.5 * (j[kLKnee] + j[kRKnee]);
  const double hips = t.hip_half + 0.085 * r * std::pow(g, 1.1);
  if (c.lower == LowerGarment::kSkirt || c.lower == LowerGarment::kDress) {
    // A-line from the waist; the hem follows the legs where it crosses them (the knees, or the
    // calves for a dress) and flares wide enough to clear them, front to back too.
    const bool dress = c.lower == LowerGarment::kDress;
    const Vector3d waist = j[kPelvis] + (dress ? 0.30 : 0.20) * t.length * t.up;
    const double down = dress ? 0.45 : 0;
    const Vector3d left = j[kLKnee] + down * (j[kLAnkle] - j[kLKnee]);
    const Vector3d right = j[kRKnee] + down * (j[kRAnkle] - j[kRKnee]);
    const Vector3d middle = 0.5 * (left + right);
    const Vector3d hem = dress ? middle : Vector3d(waist + 0.95 * (middle - waist));
    const double flare = std::max((dress ? 0.30 : 0.26) * r * std::sqrt(g),
                                  0.5 * (left - right).norm() / 0.8 + 0.08 * r);
    p.push_back(
        swept(waist, hips * 0.95, hem, flare, SubjectMaterial::kBottom, t.right_p, 1, 0.8, true));
  }
  if (c.coat) {
    const Vector3d waist = j[kPelvis] + 0.35 * t.length * t.up;
    const Vector3d thighs = 0.5 * (0.5 * (j[kLHip] + j[kRHip]) + knees);
    const double spread =
        0.5 * (0.5 * (j[kLHip] + j[kLKnee]) - 0.5 * (j[kRHip] + j[kRKnee])).norm();
    const double hem = std::max(hips + 0.05 * r, spread + 0.11 * r);
    p.push_back(swept(waist, 0.135 * r * std::pow(g, 1.3) + 0.03 * r, thighs, hem,
                      SubjectMaterial::kCoat, t.right_p, 1, 0.75, true));
  }
}

}  // namespace mocap
