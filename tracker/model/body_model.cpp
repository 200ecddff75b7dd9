// YAML loading and queries of the body model. Degrees appear only here, at the file edge.
#include "tracker/model/body_model.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include <yaml-cpp/yaml.h>

namespace mocap {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

class Parser {
 public:
  explicit Parser(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& path,
                         const std::string& reason) const {
    std::ostringstream msg;
    msg << source_;
    if (node.IsDefined() && node.Mark().line >= 0) msg << ":" << node.Mark().line + 1;
    msg << ": " << path << ": " << reason;
    throw std::runtime_error(msg.str());
  }

  // A misspelt optional key would otherwise be ignored silently (a segment without its offset, a
  // person without `kind`), so every map lists the keys it takes.
  void onlyKeys(const YAML::Node& map, const std::string& path,
                std::initializer_list<std::string_view> known) const {
    for (const auto& entry : map) {
      const std::string& key = entry.first.Scalar();
      if (std::find(known.begin(), known.end(), key) != known.end()) continue;
      std::string list;
      for (std::string_view k : known) list += (list.empty() ? "" : ", ") + std::string(k);
      fail(entry.first, path + "." + key, "unknown key (known: " + list + ")");
    }
  }

  YAML::Node require(const YAML::Node& map, const std::string& key, const std::string& path) const {
    YAML::Node child = map[key];
    if (!child) fail(map, path + "." + key, "missing");
    return child;
  }

  double number(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar()) fail(node, path, "expected a number");
    try {
      double v = node.as<double>();
      if (!std::isfinite(v)) fail(node, path, "not a finite number: '" + node.Scalar() + "'");
      return v;
    } catch (const YAML::Exception&) {
      fail(node, path, "expected a number, got '" + node.Scalar() + "'");
    }
  }

  std::string text(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar() || node.Scalar().empty()) fail(node, path, "expected a non-empty string");
    return node.Scalar();
  }

  Eigen::Vector3d vec3(const YAML::Node& node, const std::string& path) const {
    if (!node.IsSequence() || node.size() != 3) fail(node, path, "expected [x, y, z]");
    return {number(node[0], path + "[0]"), number(node[1], path + "[1]"),
            number(node[2], path + "[2]")};
  }

  Eigen::Vector3d unitVec3(const YAML::Node& node, const std::string& path) const {
    Eigen::Vector3d v = vec3(node, path);
    if (v.norm() < 1e-9) fail(node, path, "axis must not be zero");
    return v.normalized();
  }

  double positive(const YAML::Node& node, const std::string& path) const {
    double v = number(node, path);
    if (v <= 0) fail(node, path, "must be positive, got " + node.Scalar());
    return v;
  }

  Shape shape(const YAML::Node& node, const std::string& path) const {
    Shape s;
    if (!node.IsMap()) fail(node, path, "expected a map with a 'type'");
    std::string type = text(require(node, "type", path), path + ".type");
    if (type == "cone" || type == "truncated_cone") {
      onlyKeys(node, path, {"type", "axis", "length", "radius_start", "radius_end"});
      s.type = ShapeType::kTruncatedCone;
      s.axis = node["axis"] ? unitVec3(node["axis"], path + ".axis") : Eigen::Vector3d::UnitZ();
      s.length = positive(require(node, "length", path), path + ".length");
      s.radius_start = positive(require(node, "radius_start", path), path + ".radius_start");
      s.radius_end = positive(require(node, "radius_end", path), path + ".radius_end");
    } else if (type == "ellipsoid") {
      onlyKeys(node, path, {"type", "center", "radii"});
      s.type = ShapeType::kEllipsoid;
      s.center = node["center"] ? vec3(node["center"], path + ".center") : Eigen::Vector3d::Zero();
      s.radii = vec3(require(node, "radii", path), path + ".radii");
      if (s.radii.minCoeff() <= 0) fail(node["radii"], path + ".radii", "radii must be positive");
    } else {
      fail(node, path + ".type", "unknown shape '" + type + "' (expected cone or ellipsoid)");
    }
    return s;
  }

  Dof dof(const YAML::Node& node, const std::string& path) const {
    Dof d;
    if (!node.IsMap()) fail(node, path, "expected a map");
    onlyKeys(node, path, {"name", "type", "axis", "min", "max", "max_speed"});
    d.name = text(require(node, "name", path), path + ".name");
    std::string type = node["type"] ? text(node["type"], path + ".type") : "rotation";
    double unit = 1.0;
    if (type == "rotation") {
      d.type = DofType::kRotation;
      unit = kDegToRad;
    } else if (type == "translation") {
      d.type = DofType::kTranslation;
    } else {
      fail(node["type"], path + ".type",
           "unknown DOF type '" + type + "' (expected rotation or translation)");
    }
    d.axis = unitVec3(require(node, "axis", path), path + ".axis");
    d.min = number(require(node, "min", path), path + ".min") * unit;
    d.max = number(require(node, "max", path), path + ".max") * unit;
    if (d.min > d.max) fail(node, path, "min is greater than max");
    d.max_speed = positive(require(node, "max_speed", path), path + ".max_speed") * unit;
    return d;
  }

 private:
  std::string source_;
};

// The segment's DOFs, appended to the model's and indexed from `seg`.
void parseSegmentDofs(const Parser& p, const YAML::Node& dofs, const std::string& path, int index,
                      Segment& seg, BodyModel& model) {
  if (!dofs.IsSequence()) p.fail(dofs, path + ".dofs", "expected a list");
  if (dofs.size() > 6) p.fail(dofs, path + ".dofs", "a joint has at most 6 DOFs");
  for (std::size_t k = 0; k < dofs.size(); ++k) {
    std::string dpath = path + ".dofs[" + std::to_string(k) + "]";
    Dof d = p.dof(dofs[k], dpath);
    if (model.dofIndex(d.name) >= 0) p.fail(dofs[k], dpath + ".name", "duplicate DOF name");
    d.segment = index;
    seg.dofs.push_back(static_cast<int>(model.dofs.size()));
    model.dofs.push_back(d);
  }
}

void parseSegmentPoints(const Parser& p, const YAML::Node& pts, const std::string& path, int index,
                        BodyModel& model) {
  if (!pts.IsSequence()) p.fail(pts, path + ".points", "expected a list");
  for (std::size_t k = 0; k < pts.size(); ++k) {
    std::string ppath = path + ".points[" + std::to_string(k) + "]";
    if (!pts[k].IsMap()) p.fail(pts[k], ppath, "expected a map");
    p.onlyKeys(pts[k], ppath, {"name", "at"});
    BodyPoint bp;
    bp.name = p.text(p.require(pts[k], "name", ppath), ppath + ".name");
    if (model.pointIndex(bp.name) >= 0) p.fail(pts[k], ppath + ".name", "duplicate point");
    bp.segment = index;
    if (pts[k]["at"]) bp.local = p.vec3(pts[k]["at"], ppath + ".at");
    model.points.push_back(bp);
  }
}

// segments[i], appended to the model with its DOFs and points.
void parseSegment(const Parser& p, const YAML::Node& n, std::size_t i, BodyModel& model) {
  std::string path = "segments[" + std::to_string(i) + "]";
  if (!n.IsMap()) p.fail(n, path, "expected a map");
  Segment seg;
  seg.name = p.text(p.require(n, "name", path), path + ".name");
  path = "segments[" + std::to_string(i) + "] (" + seg.name + ")";
  p.onlyKeys(n, path, {"name", "parent", "offset", "dofs", "shape", "points"});
  if (model.segmentIndex(seg.name) >= 0) p.fail(n["name"], path + ".name", "duplicate segment");
  if (n["parent"] && !n["parent"].IsNull()) {
    std::string parent = p.text(n["parent"], path + ".parent");
    seg.parent = model.segmentIndex(parent);
    if (seg.parent < 0) {
      p.fail(n["parent"], path + ".parent",
             "unknown segment '" + parent + "' (parents must be listed before their children)");
    }
  } else if (!model.segments.empty()) {
    p.fail(n, path + ".parent", "missing: only the first segment may be the root");
  }
  if (n["offset"]) seg.offset = p.vec3(n["offset"], path + ".offset");
  const int index = static_cast<int>(model.segments.size());
  if (YAML::Node dofs = n["dofs"]) parseSegmentDofs(p, dofs, path, index, seg, model);
  if (n["shape"]) seg.shape = p.shape(n["shape"], path + ".shape");
  if (YAML::Node pts = n["points"]) parseSegmentPoints(p, pts, path, index, model);
  model.segments.push_back(seg);
}

// The list of names under `field`, each resolved by `index_of` to one of the model's `kind`s
// (-1: unknown), none named twice; `rule(index)` gives the field's own objection, or "".
template <typename IndexOf, typename Rule>
std::vector<std::string> parseNameList(const Parser& p, const YAML::Node& root, const char* field,
                                       const std::string& kind, IndexOf index_of, Rule rule) {
  std::vector<std::string> names;
  const YAML::Node list = root[field];
  if (!list) return names;
  if (!list.IsSequence()) p.fail(list, field, "expected a list of " + kind + " names");
  for (std::size_t k = 0; k < list.size(); ++k) {
    const std::string path = std::string(field) + "[" + std::to_string(k) + "]";
    std::string name = p.text(list[k], path);
    const int index = index_of(name);
    if (index < 0) p.fail(list[k], path, "unknown " + kind + " '" + name + "'");
    if (const std::string objection = rule(index); !objection.empty())
      p.fail(list[k], path, "'" + name + "' " + objection);
    // Named twice, an entry would count twice (a twist in the facing prior's mean).
    if (std::find(names.begin(), names.end(), name) != names.end())
      p.fail(list[k], path, "'" + name + "' is listed twice");
    names.push_back(name);
  }
  return names;
}

std::vector<std::string> parseDofNames(const Parser& p, const YAML::Node& root, const char* field,
                                       const BodyModel& model, bool rotations_only) {
  const auto index_of = [&](const std::string& name) { return model.dofIndex(name); };
  return parseNameList(p, root, field, "DOF", index_of, [&](int d) {
    return rotations_only && model.dofs[d].type != DofType::kRotation ? "is not a rotation" : "";
  });
}

// The facing prior adds the twists up, each signed by its axis against the first's: mirrored
// legs twist about opposite axes, and an axis at an angle to the first has no sign.
void checkFacingTwistAxes(const Parser& p, const YAML::Node& root, const BodyModel& model) {
  for (std::size_t k = 1; k < model.facing_twists.size(); ++k) {
    const Eigen::Vector3d& first = model.dofs[model.dofIndex(model.facing_twists[0])].axis;
    const Eigen::Vector3d& axis = model.dofs[model.dofIndex(model.facing_twists[k])].axis;
    if (std::abs(std::abs(axis.dot(first)) - 1) > 1e-9)
      p.fail(root["facing_twists"][k], "facing_twists[" + std::to_string(k) + "]",
             "'" + model.facing_twists[k] + "' turns about an axis neither along nor against '" +
                 model.facing_twists[0] + "''s");
  }
}

// Planted through the joints of its parent and grandparent (knee and hip).
std::vector<std::string> parseFeet(const Parser& p, const YAML::Node& root,
                                   const BodyModel& model) {
  return parseNameList(
      p, root, "feet", "segment", [&](const std::string& name) { return model.segmentIndex(name); },
      [&](int s) {
        const int parent = model.segments[s].parent;
        return parent < 0 || model.segments[parent].parent < 0
                   ? "needs a parent and a grandparent segment"
                   : "";
      });
}

// A stance's DOF values (every key but `name`), in the file's units, within the DOFs' limits.
void parseStanceDofs(const Parser& p, const YAML::Node& node, const std::string& path,
                     const BodyModel& model, Stance& stance) {
  for (const auto& entry : node) {
    const std::string key = entry.first.Scalar();
    if (key == "name") continue;
    const int d = model.dofIndex(key);
    if (d < 0) p.fail(entry.first, path + "." + key, "unknown DOF");
    const Dof& dof = model.dofs[d];
    const double unit = dof.type == DofType::kRotation ? kDegToRad : 1.0;
    const double value = p.number(entry.second, path + "." + key) * unit;
    if (value < dof.min - 1e-12 || value > dof.max + 1e-12)
      p.fail(entry.second, path + "." + key, "outside the DOF's limits");
    stance.dofs.emplace_back(d, value);
  }
}

void parseStances(const Parser& p, const YAML::Node& root, BodyModel& model) {
  if (const YAML::Node list = root["stances"]) {
    if (!list.IsSequence()) p.fail(list, "stances", "expected a list of stances");
    for (std::size_t k = 0; k < list.size(); ++k) {
      const std::string path = "stances[" + std::to_string(k) + "]";
      const YAML::Node node = list[k];
      if (!node.IsMap()) p.fail(node, path, "expected a map: name and DOF values");
      Stance stance;
      stance.name = p.text(p.require(node, "name", path), path + ".name");
      parseStanceDofs(p, node, path, model, stance);
      model.stances.push_back(std::move(stance));
    }
  }
  if (const YAML::Node node = root["fit_pose"]) {
    if (!node.IsMap()) p.fail(node, "fit_pose", "expected a map of DOF values");
    Stance pose;
    pose.name = "fit_pose";
    parseStanceDofs(p, node, "fit_pose", model, pose);
    model.fit_pose = std::move(pose);
  }
}

}  // namespace

BodyModel parseBodyModel(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(source + ":" + std::to_string(e.mark.line + 1) +
                             ": not valid YAML: " + e.msg);
  }
  Parser p(source);
  if (!root.IsMap()) p.fail(root, "(top)", "expected a map with 'segments'");
  p.onlyKeys(root, "(top)",
             {"name", "kind", "frame_rate", "gait_dofs", "facing_twists", "feet", "stances",
              "fit_pose", "segments"});
  BodyModel model;
  model.name = root["name"] ? p.text(root["name"], "name") : "body";
  if (root["kind"]) {
    const std::string kind = p.text(root["kind"], "kind");
    if (kind != "person" && kind != "other")
      p.fail(root["kind"], "kind", "expected person or other, got '" + kind + "'");
    model.person = kind == "person";
  }
  if (root["frame_rate"]) model.frame_rate = p.positive(root["frame_rate"], "frame_rate");
  YAML::Node segs = p.require(root, "segments", "(top)");
  if (!segs.IsSequence() || segs.size() == 0) p.fail(segs, "segments", "expected a non-empty list");
  for (std::size_t i = 0; i < segs.size(); ++i) parseSegment(p, segs[i], i, model);
  model.gait_dofs = parseDofNames(p, root, "gait_dofs", model, false);
  model.facing_twists = parseDofNames(p, root, "facing_twists", model, true);
  checkFacingTwistAxes(p, root, model);
  model.feet = parseFeet(p, root, model);
  parseStances(p, root, model);
  return model;
}

BodyModel atFrameRate(const BodyModel& model, double hz) {
  if (!(hz > 0) || !std::isfinite(hz))
    throw std::invalid_argument("frame rate must be a positive number of Hz, got " +
                                std::to_string(hz));
  BodyModel scaled = model;
  for (Dof& dof : scaled.dofs) dof.max_speed *= model.frame_rate / hz;
  scaled.frame_rate = hz;
  return scaled;
}

void moveSegmentOrigin(BodyModel& model, int segment, const Eigen::Vector3d& shift) {
  for (Segment& child : model.segments)
    if (child.parent == segment) child.offset -= shift;
  for (BodyPoint& point : model.points)
    if (point.segment == segment) point.local -= shift;
  Segment& moved = model.segments[segment];
  if (moved.shape.type == ShapeType::kEllipsoid) moved.shape.center -= shift;
  moved.offset += shift;
}

BodyModel scaledBodyModel(const BodyModel& model, double factor) {
  if (!(factor > 0) || !std::isfinite(factor))
    throw std::invalid_argument("body scale must be a positive factor, got " +
                                std::to_string(factor));
  BodyModel scaled = model;
  for (Segment& segment : scaled.segments) {
    segment.offset *= factor;
    Shape& shape = segment.shape;
    shape.length *= factor;
    shape.radius_start *= factor;
    shape.radius_end *= factor;
    shape.center *= factor;
    shape.radii *= factor;
  }
  for (BodyPoint& point : scaled.points) point.local *= factor;
  return scaled;
}

namespace {

void emitVec3(YAML::Emitter& out, const Eigen::Vector3d& v) {
  out << YAML::Flow << YAML::BeginSeq << v.x() << v.y() << v.z() << YAML::EndSeq;
}

void emitShape(YAML::Emitter& out, const Shape& shape) {
  out << YAML::Flow << YAML::BeginMap;
  if (shape.type == ShapeType::kTruncatedCone) {
    out << YAML::Key << "type" << YAML::Value << "cone" << YAML::Key << "axis" << YAML::Value;
    emitVec3(out, shape.axis);
    out << YAML::Key << "length" << YAML::Value << shape.length;
    out << YAML::Key << "radius_start" << YAML::Value << shape.radius_start;
    out << YAML::Key << "radius_end" << YAML::Value << shape.radius_end;
  } else {
    out << YAML::Key << "type" << YAML::Value << "ellipsoid" << YAML::Key << "center"
        << YAML::Value;
    emitVec3(out, shape.center);
    out << YAML::Key << "radii" << YAML::Value;
    emitVec3(out, shape.radii);
  }
  out << YAML::EndMap;
}

}  // namespace

std::string formatBodyModel(const BodyModel& model) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // enough digits to read back the same double
  out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << model.name;
  if (model.person) out << YAML::Key << "kind" << YAML::Value << "person";
  out << YAML::Key << "frame_rate" << YAML::Value << model.frame_rate;
  if (!model.gait_dofs.empty()) {
    out << YAML::Key << "gait_dofs" << YAML::Value << YAML::Flow << model.gait_dofs;
  }
  if (!model.facing_twists.empty()) {
    out << YAML::Key << "facing_twists" << YAML::Value << YAML::Flow << model.facing_twists;
  }
  if (!model.feet.empty()) out << YAML::Key << "feet" << YAML::Value << YAML::Flow << model.feet;
  if (!model.stances.empty()) {
    out << YAML::Key << "stances" << YAML::Value << YAML::BeginSeq;
    for (const Stance& stance : model.stances) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << stance.name;
      for (const auto& [d, value] : stance.dofs) {
        const double unit = model.dofs[d].type == DofType::kRotation ? 1.0 / kDegToRad : 1.0;
        out << YAML::Key << model.dofs[d].name << YAML::Value << value * unit;
      }
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  if (model.fit_pose) {
    out << YAML::Key << "fit_pose" << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (const auto& [d, value] : model.fit_pose->dofs) {
      const double unit = model.dofs[d].type == DofType::kRotation ? 1.0 / kDegToRad : 1.0;
      out << YAML::Key << model.dofs[d].name << YAML::Value << value * unit;
    }
    out << YAML::EndMap;
  }
  out << YAML::Key << "segments" << YAML::Value << YAML::BeginSeq;
  for (std::size_t s = 0; s < model.segments.size(); ++s) {
    const Segment& seg = model.segments[s];
    out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << seg.name;
    if (seg.parent >= 0)
      out << YAML::Key << "parent" << YAML::Value << model.segments[seg.parent].name;
    out << YAML::Key << "offset" << YAML::Value;
    emitVec3(out, seg.offset);
    if (!seg.dofs.empty()) {
      out << YAML::Key << "dofs" << YAML::Value << YAML::BeginSeq;
      for (int d : seg.dofs) {
        const Dof& dof = model.dofs[d];
        const bool rotation = dof.type == DofType::kRotation;
        const double unit = rotation ? 1.0 / kDegToRad : 1.0;
        out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << dof.name;
        out << YAML::Key << "type" << YAML::Value << (rotation ? "rotation" : "translation");
        out << YAML::Key << "axis" << YAML::Value;
        emitVec3(out, dof.axis);
        out << YAML::Key << "min" << YAML::Value << dof.min * unit;
        out << YAML::Key << "max" << YAML::Value << dof.max * unit;
        out << YAML::Key << "max_speed" << YAML::Value << dof.max_speed * unit << YAML::EndMap;
      }
      out << YAML::EndSeq;
    }
    if (seg.shape.type != ShapeType::kNone) {
      out << YAML::Key << "shape" << YAML::Value;
      emitShape(out, seg.shape);
    }
    bool any_point = false;
    for (const BodyPoint& point : model.points) {
      if (point.segment != static_cast<int>(s)) continue;
      if (!any_point) out << YAML::Key << "points" << YAML::Value << YAML::BeginSeq;
      any_point = true;
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << point.name;
      out << YAML::Key << "at" << YAML::Value;
      emitVec3(out, point.local);
      out << YAML::EndMap;
    }
    if (any_point) out << YAML::EndSeq;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

BodyModel loadBodyModel(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open body model file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return parseBodyModel(buffer.str(), path);
}

int BodyModel::segmentIndex(const std::string& segment_name) const {
  for (std::size_t i = 0; i < segments.size(); ++i)
    if (segments[i].name == segment_name) return static_cast<int>(i);
  return -1;
}

int BodyModel::dofIndex(const std::string& dof_name) const {
  for (std::size_t i = 0; i < dofs.size(); ++i)
    if (dofs[i].name == dof_name) return static_cast<int>(i);
  return -1;
}

int BodyModel::pointIndex(const std::string& point_name) const {
  for (std::size_t i = 0; i < points.size(); ++i)
    if (points[i].name == point_name) return static_cast<int>(i);
  return -1;
}

Eigen::VectorXd BodyModel::neutralPose() const {
  Eigen::VectorXd q(dofs.size());
  for (std::size_t i = 0; i < dofs.size(); ++i) q[i] = std::clamp(0.0, dofs[i].min, dofs[i].max);
  return q;
}

Eigen::VectorXd BodyModel::stancePose(const Stance& stance) const {
  Eigen::VectorXd q = neutralPose();
  for (const auto& [d, value] : stance.dofs) q[d] = value;
  return q;
}

bool BodyModel::isStatic(int s) const {
  for (; s >= 0; s = segments[s].parent)
    for (int d : segments[s].dofs)
      if (dofs[d].isFree()) return false;
  return true;
}

BodyModel freezeAllBut(const BodyModel& model, const std::vector<std::string>& free_dofs,
                       const Eigen::VectorXd& pose) {
  for (const std::string& name : free_dofs)
    if (model.dofIndex(name) < 0) throw std::invalid_argument("unknown DOF '" + name + "'");
  BodyModel out = model;
  for (std::size_t d = 0; d < out.dofs.size(); ++d) {
    Dof& dof = out.dofs[d];
    if (std::find(free_dofs.begin(), free_dofs.end(), dof.name) != free_dofs.end()) continue;
    dof.min = dof.max = pose[static_cast<long>(d)];
  }
  // A frozen DOF holds its value in every stance too.
  for (Stance& stance : out.stances)
    for (auto& [d, value] : stance.dofs)
      value = std::clamp(value, out.dofs[d].min, out.dofs[d].max);
  if (out.fit_pose)
    for (auto& [d, value] : out.fit_pose->dofs)
      value = std::clamp(value, out.dofs[d].min, out.dofs[d].max);
  return out;
}

}  // namespace mocap
