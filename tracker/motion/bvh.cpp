// BVH reading and skeleton forward kinematics. The hierarchy is read as a token stream (BVH does
// not care about line breaks there); the MOTION section is read line by line, one frame a line.
#include "tracker/motion/bvh.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>

namespace mocap {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

struct Token {
  std::string text;
  int line = 0;
};

std::vector<std::string> splitWords(const std::string& line) {
  std::vector<std::string> words;
  std::istringstream in(line);
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

std::optional<double> parseNumber(const std::string& text) {
  double v = 0;
  const char* end = text.data() + text.size();
  // from_chars rejects a leading '+', which some exporters write.
  const char* begin = text.data() + (text.size() > 1 && text[0] == '+' ? 1 : 0);
  const auto [ptr, ec] = std::from_chars(begin, end, v);
  if (ec != std::errc() || ptr != end || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<BvhChannel> parseChannel(const std::string& name) {
  static const std::map<std::string, BvhChannel> kByName = {
      {"Xposition", BvhChannel::kXposition}, {"Yposition", BvhChannel::kYposition},
      {"Zposition", BvhChannel::kZposition}, {"Xrotation", BvhChannel::kXrotation},
      {"Yrotation", BvhChannel::kYrotation}, {"Zrotation", BvhChannel::kZrotation}};
  auto it = kByName.find(name);
  if (it == kByName.end()) return std::nullopt;
  return it->second;
}

class Parser {
 public:
  Parser(const std::string& text, std::string source) : source_(std::move(source)) {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      lines_.push_back(line);
    }
  }

  Bvh parse() {
    Bvh bvh;
    const std::size_t motion_line = findMotionLine();
    for (std::size_t i = 0; i < motion_line; ++i)
      for (std::string& w : splitWords(lines_[i])) tokens_.push_back({w, static_cast<int>(i) + 1});

    if (tokens_.empty() || tokens_[0].text != "HIERARCHY")
      fail(tokens_.empty() ? 1 : tokens_[0].line, "expected 'HIERARCHY' at the start of the file");
    next_ = 1;
    const Token& root = take("'ROOT'");
    if (root.text != "ROOT") fail(root.line, "expected 'ROOT', got '" + root.text + "'");
    parseJoint(bvh.skeleton, -1, take("the root joint's name").text, root.line, false);
    if (next_ < tokens_.size()) {
      fail(tokens_[next_].line, "unexpected '" + tokens_[next_].text +
                                    "' after the root joint (expected MOTION; one root only)");
    }
    parseMotion(bvh, motion_line);
    return bvh;
  }

 private:
  [[noreturn]] void fail(int line, const std::string& reason) const {
    throw std::runtime_error(source_ + ":" + std::to_string(line) + ": " + reason);
  }

  std::size_t findMotionLine() const {
    for (std::size_t i = 0; i < lines_.size(); ++i) {
      const std::vector<std::string> words = splitWords(lines_[i]);
      if (!words.empty() && words[0] == "MOTION") return i;
    }
    fail(static_cast<int>(lines_.size()), "missing the MOTION section");
  }

  int lastLine() const { return tokens_.empty() ? 1 : tokens_.back().line; }

  const Token& take(const std::string& what) {
    if (next_ >= tokens_.size())
      fail(lastLine(), "unexpected end of the hierarchy: expected " + what);
    return tokens_[next_++];
  }

  double number(const std::string& what) {
    const Token& t = take(what);
    const std::optional<double> v = parseNumber(t.text);
    if (!v) fail(t.line, what + ": not a number: '" + t.text + "'");
    return *v;
  }

  void parseJoint(BvhSkeleton& skeleton, int parent, const std::string& name, int line,
                  bool end_site) {
    // A person is about ten joints deep; a limit keeps a malformed file from exhausting the stack.
    constexpr int kMaxDepth = 256;
    if (++depth_ > kMaxDepth)
      fail(line, "joints nested deeper than " + std::to_string(kMaxDepth) + " levels");
    const int index = static_cast<int>(skeleton.joints.size());
    skeleton.joints.push_back({});
    skeleton.joints[index].name = name;
    skeleton.joints[index].parent = parent;
    skeleton.joints[index].is_end_site = end_site;
    skeleton.joints[index].first_channel = skeleton.channel_count;
    const std::string what = end_site ? "the End Site of '" + skeleton.joints[parent].name + "'"
                                      : "joint '" + name + "'";
    if (const Token& open = take("'{' opening " + what); open.text != "{")
      fail(open.line, "expected '{' opening " + what + ", got '" + open.text + "'");
    bool has_offset = false, has_channels = false;
    for (;;) {
      if (next_ >= tokens_.size())
        fail(lastLine(),
             "missing '}' closing " + what + " (opened at line " + std::to_string(line) + ")");
      const Token& keyword = tokens_[next_++];
      if (keyword.text == "}") break;
      if (keyword.text == "OFFSET") {
        if (has_offset) fail(keyword.line, what + ": a second OFFSET");
        for (int k = 0; k < 3; ++k) skeleton.joints[index].offset[k] = number(what + " OFFSET");
        has_offset = true;
      } else if (keyword.text == "CHANNELS") {
        if (end_site) fail(keyword.line, what + ": an End Site has no CHANNELS");
        if (has_channels) fail(keyword.line, what + ": a second CHANNELS");
        parseChannels(skeleton, index, what);
        has_channels = true;
      } else if (keyword.text == "JOINT") {
        if (end_site) fail(keyword.line, what + ": an End Site has no child joints");
        parseJoint(skeleton, index, take("a joint name after JOINT").text, keyword.line, false);
      } else if (keyword.text == "End") {
        if (end_site) fail(keyword.line, what + ": an End Site has no child joints");
        if (const Token& site = take("'Site' after 'End'"); site.text != "Site")
          fail(site.line, "expected 'Site' after 'End', got '" + site.text + "'");
        parseJoint(skeleton, index, name + "_End", keyword.line, true);
      } else {
        fail(keyword.line, "unknown keyword '" + keyword.text + "' in " + what +
                               " (expected OFFSET, CHANNELS, JOINT, End Site or '}')");
      }
    }
    if (!has_offset) fail(line, what + ": missing OFFSET");
    --depth_;
  }

  void parseChannels(BvhSkeleton& skeleton, int index, const std::string& what) {
    const Token& count_token = take(what + " channel count");
    const std::optional<double> count = parseNumber(count_token.text);
    if (!count || *count != std::floor(*count) || *count < 0 || *count > 6)
      fail(count_token.line,
           what + ": channel count must be 0 to 6, got '" + count_token.text + "'");
    BvhJoint& joint = skeleton.joints[index];
    for (int k = 0; k < static_cast<int>(*count); ++k) {
      const Token& t = take(what + " channel name");
      const std::optional<BvhChannel> channel = parseChannel(t.text);
      if (!channel) {
        fail(t.line, what + ": unknown channel '" + t.text +
                         "' (expected X/Y/Zposition or X/Y/Zrotation; CHANNELS " +
                         count_token.text + " lists " + count_token.text + " names)");
      }
      for (BvhChannel c : joint.channels)
        if (c == *channel) fail(t.line, what + ": channel '" + t.text + "' listed twice");
      joint.channels.push_back(*channel);
    }
    skeleton.channel_count += static_cast<int>(joint.channels.size());
  }

  // Reads "<label> <value>" from the first non-blank line at or after `i`; returns the value.
  double header(std::size_t& i, const std::vector<std::string>& label, const std::string& spelled) {
    while (i < lines_.size() && splitWords(lines_[i]).empty()) ++i;
    const int line = static_cast<int>(std::min(i, lines_.size() - 1)) + 1;
    if (i >= lines_.size()) fail(line, "missing '" + spelled + "' after MOTION");
    const std::vector<std::string> words = splitWords(lines_[i]);
    if (words.size() != label.size() + 1 || !std::equal(label.begin(), label.end(), words.begin()))
      fail(line, "expected '" + spelled + " <value>', got '" + lines_[i] + "'");
    const std::optional<double> v = parseNumber(words.back());
    if (!v) fail(line, spelled + ": not a number: '" + words.back() + "'");
    ++i;
    return *v;
  }

  void parseMotion(Bvh& bvh, std::size_t motion_line) {
    std::size_t i = motion_line + 1;
    const int frames_line = static_cast<int>(i) + 1;
    const double declared = header(i, {"Frames:"}, "Frames:");
    if (declared < 0 || declared != std::floor(declared))
      fail(static_cast<int>(i), "Frames: must be a whole number >= 0");
    // Checked before the count becomes an integer, which cannot hold every number a file may write.
    if (declared > static_cast<double>(lines_.size()))
      fail(static_cast<int>(i), "Frames: more frames than the file has lines (" +
                                    std::to_string(lines_.size()) + ")");
    const double frame_time = header(i, {"Frame", "Time:"}, "Frame Time:");
    if (frame_time <= 0) fail(static_cast<int>(i), "Frame Time: must be positive");
    bvh.motion.frame_time = frame_time;

    const long expected = static_cast<long>(declared);
    const int channels = bvh.skeleton.channel_count;
    for (; i < lines_.size(); ++i) {
      const std::vector<std::string> words = splitWords(lines_[i]);
      if (words.empty()) continue;
      const int line = static_cast<int>(i) + 1;
      const long frame = static_cast<long>(bvh.motion.frames.size());
      if (frame >= expected) {
        fail(line, "more frame lines than the " + std::to_string(expected) +
                       " declared by 'Frames:' (line " + std::to_string(frames_line) + ")");
      }
      if (static_cast<int>(words.size()) != channels) {
        fail(line, "frame " + std::to_string(frame) + " has " + std::to_string(words.size()) +
                       " values, the hierarchy has " + std::to_string(channels) + " channels");
      }
      Eigen::VectorXd values(channels);
      for (int c = 0; c < channels; ++c) {
        const std::optional<double> v = parseNumber(words[c]);
        if (!v) {
          fail(line, "frame " + std::to_string(frame) + ", value " + std::to_string(c + 1) +
                         ": not a number: '" + words[c] + "'");
        }
        values[c] = *v;
      }
      bvh.motion.frames.push_back(std::move(values));
    }
    if (static_cast<long>(bvh.motion.frames.size()) != expected) {
      fail(static_cast<int>(lines_.size()),
           "'Frames: " + std::to_string(expected) + "' (line " + std::to_string(frames_line) +
               ") but the file has " + std::to_string(bvh.motion.frames.size()) + " frame lines");
    }
  }

  std::string source_;
  std::vector<std::string> lines_;
  std::vector<Token> tokens_;
  std::size_t next_ = 0;
  int depth_ = 0;  // of the joint being parsed
};

}  // namespace

int BvhSkeleton::jointIndex(const std::string& joint_name) const {
  for (std::size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == joint_name) return static_cast<int>(j);
  return -1;
}

int BvhSkeleton::endSiteOf(int j) const {
  for (std::size_t k = 0; k < joints.size(); ++k)
    if (joints[k].parent == j && joints[k].is_end_site) return static_cast<int>(k);
  return -1;
}

Bvh parseBvh(const std::string& text, const std::string& source) {
  Bvh bvh = Parser(text, source).parse();
  bvh.skeleton.source = source;
  return bvh;
}

Bvh loadBvh(const std::string& path, const BvhLoadOptions& options) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open BVH file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  Bvh bvh = parseBvh(buffer.str(), path);
  prepareBvh(bvh, options);
  return bvh;
}

std::vector<Eigen::Vector3d> bvhJointPositions(const BvhSkeleton& skeleton,
                                               const Eigen::VectorXd& frame) {
  std::vector<Eigen::Isometry3d> world(skeleton.joints.size());
  std::vector<Eigen::Vector3d> positions(skeleton.joints.size());
  for (std::size_t j = 0; j < skeleton.joints.size(); ++j) {
    const BvhJoint& joint = skeleton.joints[j];
    Eigen::Vector3d translation = joint.offset;
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    for (std::size_t c = 0; c < joint.channels.size(); ++c) {
      const double v = frame[joint.first_channel + static_cast<long>(c)];
      switch (joint.channels[c]) {
        case BvhChannel::kXposition:
          translation.x() += v;
          break;
        case BvhChannel::kYposition:
          translation.y() += v;
          break;
        case BvhChannel::kZposition:
          translation.z() += v;
          break;
        case BvhChannel::kXrotation:
          rotation = rotation * Eigen::AngleAxisd(v * kDegToRad, Eigen::Vector3d::UnitX());
          break;
        case BvhChannel::kYrotation:
          rotation = rotation * Eigen::AngleAxisd(v * kDegToRad, Eigen::Vector3d::UnitY());
          break;
        case BvhChannel::kZrotation:
          rotation = rotation * Eigen::AngleAxisd(v * kDegToRad, Eigen::Vector3d::UnitZ());
          break;
      }
    }
    Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
    local.translation() = translation;
    local.linear() = rotation;
    world[j] = joint.parent < 0 ? local : world[joint.parent] * local;
    positions[j] = world[j].translation();
  }
  return positions;
}

std::vector<Eigen::Vector3d> bvhRestPositions(const BvhSkeleton& skeleton) {
  return bvhJointPositions(skeleton, Eigen::VectorXd::Zero(skeleton.channel_count));
}

}  // namespace mocap

namespace mocap {
namespace {

struct UnitName {
  BvhUnits units;
  const char* name;
  double metres;
};
constexpr UnitName kUnitNames[] = {
    {BvhUnits::kAuto, "auto", 0},
    {BvhUnits::kMetres, "m", 1},
    {BvhUnits::kCentimetres, "cm", 0.01},
    {BvhUnits::kMillimetres, "mm", 0.001},
    {BvhUnits::kCmu, "cmu", kCmuMetresPerUnit},
    {BvhUnits::kInches, "inch", 0.0254},
};

// An angle's distance from zero, in degrees, whatever number of turns it carries.
double wrappedDegrees(double degrees) { return std::abs(std::remainder(degrees, 360.0)); }

bool isRotation(BvhChannel c) {
  return c == BvhChannel::kXrotation || c == BvhChannel::kYrotation || c == BvhChannel::kZrotation;
}

// A frame of the reference pose: the root's rotation and most joint angles zero.
bool isReferencePose(const BvhSkeleton& skeleton, const Eigen::VectorXd& frame) {
  int zero = 0, angles = 0;
  for (std::size_t j = 0; j < skeleton.joints.size(); ++j) {
    const BvhJoint& joint = skeleton.joints[j];
    for (std::size_t c = 0; c < joint.channels.size(); ++c) {
      if (!isRotation(joint.channels[c])) continue;
      const bool is_zero = wrappedDegrees(frame[joint.first_channel + static_cast<long>(c)]) < 1e-3;
      if (joint.parent < 0 && !is_zero) return false;
      if (joint.parent < 0) continue;
      zero += is_zero;
      ++angles;
    }
  }
  return angles > 0 && zero >= 0.75 * angles;
}

// The mean change of the rotation channels from frame a to frame b, in degrees.
double meanRotationChange(const BvhSkeleton& skeleton, const Eigen::VectorXd& a,
                          const Eigen::VectorXd& b) {
  double sum = 0;
  int count = 0;
  for (const BvhJoint& joint : skeleton.joints) {
    for (std::size_t c = 0; c < joint.channels.size(); ++c) {
      if (!isRotation(joint.channels[c])) continue;
      const long k = joint.first_channel + static_cast<long>(c);
      sum += wrappedDegrees(b[k] - a[k]);
      ++count;
    }
  }
  return count ? sum / count : 0;
}

}  // namespace

BvhUnits parseBvhUnits(const std::string& text) {
  std::string names;
  for (const UnitName& u : kUnitNames) {
    if (text == u.name) return u.units;
    names += std::string(names.empty() ? "" : ", ") + u.name;
  }
  throw std::invalid_argument("BVH units: expected one of " + names + ", got '" + text + "'");
}

const char* bvhUnitsName(BvhUnits units) {
  for (const UnitName& u : kUnitNames)
    if (u.units == units) return u.name;
  return "?";
}

double metresPerUnit(BvhUnits units) {
  if (units == BvhUnits::kAuto)
    throw std::invalid_argument("metresPerUnit: 'auto' is no unit; detect it (detectBvhUnits)");
  for (const UnitName& u : kUnitNames)
    if (u.units == units) return u.metres;
  throw std::invalid_argument("metresPerUnit: unknown BvhUnits value");
}

double bvhRestSize(const BvhSkeleton& skeleton) {
  const std::vector<Eigen::Vector3d> rest = bvhRestPositions(skeleton);
  if (rest.empty()) return 0;
  Eigen::Vector3d low = rest[0], high = rest[0];
  for (const Eigen::Vector3d& p : rest) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  return (high - low).maxCoeff();
}

BvhUnits detectBvhUnits(const BvhSkeleton& skeleton) {
  constexpr double kPersonSize = 1.7;  // metres
  const double size = bvhRestSize(skeleton);
  BvhUnits best = BvhUnits::kMetres;
  double best_distance = INFINITY;
  for (BvhUnits units :
       {BvhUnits::kMetres, BvhUnits::kCentimetres, BvhUnits::kMillimetres, BvhUnits::kCmu}) {
    const double distance = std::abs(std::log(size * metresPerUnit(units) / kPersonSize));
    if (distance < best_distance) {
      best = units;
      best_distance = distance;
    }
  }
  const double metres = size * metresPerUnit(best);
  if (!(metres >= 0.5 && metres <= 3.5)) {
    std::ostringstream msg;
    msg << skeleton.source << ": cannot tell the length unit: the skeleton's rest pose is " << size
        << " units across, no person's size in m, cm, mm or CMU units; force the units";
    throw std::runtime_error(msg.str());
  }
  return best;
}

int referencePoseFrames(const BvhSkeleton& skeleton, const BvhMotion& motion) {
  constexpr int kMotionSample = 10;  // frames after the reference pose whose change sets the scale
  const int frames = static_cast<int>(motion.frames.size());
  int reference = 0;
  while (reference + 2 < frames && isReferencePose(skeleton, motion.frames[reference])) ++reference;
  if (reference == 0) return 0;
  const double jump =
      meanRotationChange(skeleton, motion.frames[reference - 1], motion.frames[reference]);
  std::vector<double> changes;
  for (int k = reference; k + 1 < frames && k < reference + kMotionSample; ++k)
    changes.push_back(meanRotationChange(skeleton, motion.frames[k], motion.frames[k + 1]));
  std::nth_element(changes.begin(), changes.begin() + changes.size() / 2, changes.end());
  const double motion_change = changes[changes.size() / 2];
  return jump > 2 && jump > 5 * motion_change ? reference : 0;
}

void prepareBvh(Bvh& bvh, const BvhLoadOptions& options) {
  if (options.metres_per_unit < 0 || !std::isfinite(options.metres_per_unit))
    throw std::invalid_argument("BVH metres per unit: expected a positive factor");
  const double factor = options.metres_per_unit > 0 ? options.metres_per_unit
                        : options.units == BvhUnits::kAuto
                            ? metresPerUnit(detectBvhUnits(bvh.skeleton))
                            : metresPerUnit(options.units);
  // A file already in metres is left as read, bit for bit.
  if (factor != 1) {
    for (BvhJoint& joint : bvh.skeleton.joints) {
      joint.offset *= factor;
      for (std::size_t c = 0; c < joint.channels.size(); ++c) {
        if (isRotation(joint.channels[c])) continue;
        for (Eigen::VectorXd& frame : bvh.motion.frames)
          frame[joint.first_channel + static_cast<long>(c)] *= factor;
      }
    }
  }
  bvh.metres_per_unit = factor;
  if (options.skip_reference_pose) {
    bvh.reference_frames = referencePoseFrames(bvh.skeleton, bvh.motion);
    bvh.motion.frames.erase(bvh.motion.frames.begin(),
                            bvh.motion.frames.begin() + bvh.reference_frames);
  }
  if (!options.joint_map.empty()) {
    auto map = std::make_shared<const JointMap>(loadJointMap(options.joint_map));
    checkJointMap(*map, bvh.skeleton);
    bvh.skeleton.joint_map = std::move(map);
  }
}

}  // namespace mocap
