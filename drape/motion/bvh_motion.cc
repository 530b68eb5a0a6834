#include "drape/motion/bvh_motion.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace polyfit {
namespace {

enum class Channel { kXpos, kYpos, kZpos, kXrot, kYrot, kZrot };

struct Tokenizer {
  std::istream& in;
  std::string path;
  int line = 1;
  // The character that ended the last token (a newline, say).
  char terminator = 0;

  // The next whitespace-separated token; empty at the end.
  std::string Next() {
    std::string token;
    char c;
    terminator = 0;
    while (in.get(c)) {
      if (c == '\n') ++line;
      if (std::isspace(static_cast<unsigned char>(c))) {
        if (!token.empty()) {
          terminator = c;
          return token;
        }
        continue;
      }
      token += c;
    }
    return token;
  }
  [[noreturn]] void Fail(const std::string& reason) const {
    throw BvhError(path + ": line " + std::to_string(line) + ": " + reason);
  }
  std::string Expect(const char* what) {
    const std::string token = Next();
    if (token != what) Fail(std::string("expected '") + what + "', found '" + token + "'");
    return token;
  }
  double Number() {
    const std::string token = Next();
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (token.empty() || *end != '\0') Fail("expected a number, found '" + token + "'");
    if (!std::isfinite(value)) Fail("non-finite value '" + token + "'");
    return value;
  }
};

Eigen::Quaterniond AxisRotation(Channel c, double degrees) {
  const double radians = degrees * M_PI / 180.0;
  const Eigen::Vector3d axis = c == Channel::kXrot   ? Eigen::Vector3d::UnitX()
                               : c == Channel::kYrot ? Eigen::Vector3d::UnitY()
                                                     : Eigen::Vector3d::UnitZ();
  return Eigen::Quaterniond(Eigen::AngleAxisd(radians, axis));
}

}  // namespace

int MotionClip::FindJoint(const std::string& name) const {
  for (int j = 0; j < num_joints(); ++j) {
    if (joints[j].name == name) return j;
  }
  return -1;
}

std::vector<Eigen::Isometry3d> MotionClip::GlobalTransforms(int f) const {
  const MotionFrame& frame = frames.at(f);
  std::vector<Eigen::Isometry3d> global(joints.size());
  for (int j = 0; j < num_joints(); ++j) {
    Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
    local.linear() = frame.local_rotations[j].toRotationMatrix();
    local.translation() = joints[j].parent < 0 ? frame.root_translation : joints[j].offset;
    global[j] = joints[j].parent < 0 ? local : global[joints[j].parent] * local;
  }
  return global;
}

MotionClip MotionClip::Resampled(double target_fps) const {
  if (!(target_fps > 0.0) || !(fps > 0.0) || frames.empty()) {
    throw std::invalid_argument("MotionClip::Resampled: needs positive frame rates and at least one frame");
  }
  MotionClip out;
  out.joints = joints;
  out.fps = target_fps;
  const double duration = (num_frames() - 1) / fps;
  const int count = static_cast<int>(std::floor(duration * target_fps + 1e-9)) + 1;
  for (int k = 0; k < count; ++k) {
    const double source = k / target_fps * fps;
    const int i0 = std::min(static_cast<int>(std::floor(source)), num_frames() - 1);
    const int i1 = std::min(i0 + 1, num_frames() - 1);
    const double t = source - i0;
    MotionFrame frame;
    frame.root_translation = (1 - t) * frames[i0].root_translation + t * frames[i1].root_translation;
    frame.local_rotations.resize(joints.size());
    for (int j = 0; j < num_joints(); ++j) {
      frame.local_rotations[j] = frames[i0].local_rotations[j].slerp(t, frames[i1].local_rotations[j]);
    }
    out.frames.push_back(std::move(frame));
  }
  return out;
}

Eigen::Vector3d MotionClip::RootVelocity(int f) const {
  if (num_frames() < 2) return Eigen::Vector3d::Zero();
  const int a = std::max(0, f - 1), b = std::min(num_frames() - 1, f + 1);
  return (frames[b].root_translation - frames[a].root_translation) * fps / (b - a);
}

namespace {

// One ROOT or JOINT: name, OFFSET, CHANNELS (the keyword already read).
MotionJoint ReadJointHeader(Tokenizer& tokens, double units_to_metres, std::vector<Channel>* channels) {
  MotionJoint joint;
  joint.name = tokens.Next();
  tokens.Expect("{");
  tokens.Expect("OFFSET");
  for (int k = 0; k < 3; ++k) joint.offset[k] = tokens.Number() * units_to_metres;
  tokens.Expect("CHANNELS");
  const double count = tokens.Number();
  if (count < 0 || count > 6 || count != std::floor(count)) tokens.Fail("bad channel count");
  static const std::pair<const char*, Channel> kNames[] = {
      {"Xposition", Channel::kXpos}, {"Yposition", Channel::kYpos}, {"Zposition", Channel::kZpos},
      {"Xrotation", Channel::kXrot}, {"Yrotation", Channel::kYrot}, {"Zrotation", Channel::kZrot}};
  for (int k = 0; k < static_cast<int>(count); ++k) {
    const std::string name = tokens.Next();
    const auto* it = std::find_if(std::begin(kNames), std::end(kNames), [&](const auto& e) { return name == e.first; });
    if (it == std::end(kNames)) tokens.Fail("unknown channel '" + name + "'");
    channels->push_back(it->second);
  }
  return joint;
}

// HIERARCHY: the joints (parents before children) and their channels.
void ReadHierarchy(Tokenizer& tokens, double units_to_metres, MotionClip* clip,
                   std::vector<std::vector<Channel>>* channels) {
  tokens.Expect("HIERARCHY");
  std::vector<int> stack;  // open joints
  std::string token = tokens.Next();
  if (token != "ROOT") tokens.Fail("expected 'ROOT', found '" + token + "'");
  for (;;) {
    if (token == "ROOT" || token == "JOINT") {
      if (token == "ROOT" && !clip->joints.empty()) tokens.Fail("a second ROOT is not supported");
      const int parent = stack.empty() ? -1 : stack.back();
      std::vector<Channel> list;
      MotionJoint joint = ReadJointHeader(tokens, units_to_metres, &list);
      joint.parent = parent;
      if (token == "JOINT" && parent < 0) tokens.Fail("JOINT '" + joint.name + "' outside any joint");
      stack.push_back(static_cast<int>(clip->joints.size()));
      clip->joints.push_back(joint);
      channels->push_back(list);
    } else if (token == "End") {
      tokens.Expect("Site");
      tokens.Expect("{");
      tokens.Expect("OFFSET");
      for (int k = 0; k < 3; ++k) tokens.Number();
      tokens.Expect("}");
    } else if (token == "}") {
      if (stack.empty()) tokens.Fail("unbalanced '}'");
      stack.pop_back();
      if (stack.empty()) return;
    } else {
      tokens.Fail("unexpected '" + token + "' in HIERARCHY");
    }
    token = tokens.Next();
    if (token.empty()) tokens.Fail("the file ends inside HIERARCHY (unbalanced braces?)");
  }
}

// One frame's values applied to the joints: the root's position, every
// joint's rotation in its channels' order.
MotionFrame FrameFromValues(const MotionClip& clip, const std::vector<std::vector<Channel>>& channels,
                            const std::vector<double>& row, double units_to_metres) {
  MotionFrame frame;
  frame.local_rotations.assign(clip.joints.size(), Eigen::Quaterniond::Identity());
  size_t k = 0;
  for (size_t j = 0; j < clip.joints.size(); ++j) {
    Eigen::Vector3d position = clip.joints[j].offset;
    for (const Channel c : channels[j]) {
      const double value = row[k++];
      switch (c) {
        case Channel::kXpos: position.x() = value * units_to_metres; break;
        case Channel::kYpos: position.y() = value * units_to_metres; break;
        case Channel::kZpos: position.z() = value * units_to_metres; break;
        default: frame.local_rotations[j] = frame.local_rotations[j] * AxisRotation(c, value); break;
      }
    }
    if (j == 0) frame.root_translation = position;
  }
  return frame;
}

// MOTION: the frame count and time, then one line per frame, so that a
// short or long line is named.
void ReadMotion(std::istream& in, Tokenizer& tokens, const std::string& path,
                const std::vector<std::vector<Channel>>& channels, double units_to_metres, MotionClip* clip) {
  tokens.Expect("MOTION");
  tokens.Expect("Frames:");
  const double num_frames = tokens.Number();
  // Frames are read one per line, never preallocated: the bound only keeps
  // the count an int.
  if (num_frames < 1 || num_frames > 1e9 || num_frames != std::floor(num_frames)) tokens.Fail("bad frame count");
  const int frame_count = static_cast<int>(num_frames);
  tokens.Expect("Frame");
  tokens.Expect("Time:");
  const double frame_time = tokens.Number();
  // Beyond 10 kHz (or below a frame a minute) a clip resampled to a frame
  // rate would take more frames than memory holds.
  if (!(frame_time >= 1e-4 && frame_time <= 60.0)) tokens.Fail("the frame time must be in [1e-4, 60] s");
  clip->fps = 1.0 / frame_time;
  int total_channels = 0;
  for (const auto& list : channels) total_channels += static_cast<int>(list.size());
  // The rest of the Frame Time line; line_number: the line before the
  // first frame's.
  std::string line;
  int line_number = tokens.line - 1;
  if (tokens.terminator != '\n') {
    std::getline(in, line);
    line_number = tokens.line;
  }
  for (int f = 0; f < frame_count;) {
    if (!std::getline(in, line)) {
      tokens.line = line_number;
      tokens.Fail("the file ends after " + std::to_string(f) + " of " + std::to_string(frame_count) + " frames");
    }
    ++line_number;
    const std::string where = path + ": line " + std::to_string(line_number) + ": frame " + std::to_string(f);
    std::istringstream values(line);
    std::vector<double> row;
    std::string token;
    while (values >> token) {
      char* end = nullptr;
      const double value = std::strtod(token.c_str(), &end);
      if (*end != '\0' || !std::isfinite(value)) throw BvhError(where + ": bad value '" + token + "'");
      row.push_back(value);
    }
    if (row.empty()) continue;  // blank line
    if (static_cast<int>(row.size()) != total_channels) {
      throw BvhError(where + " has " + std::to_string(row.size()) + " values, expected " +
                     std::to_string(total_channels));
    }
    clip->frames.push_back(FrameFromValues(*clip, channels, row, units_to_metres));
    ++f;
  }
}

}  // namespace

MotionClip ReadBvh(const std::string& path, double units_to_metres) {
  std::ifstream in(path);
  if (!in) throw BvhError(path + ": cannot be opened (missing?)");
  Tokenizer tokens{in, path};
  MotionClip clip;
  std::vector<std::vector<Channel>> channels;  // per joint
  ReadHierarchy(tokens, units_to_metres, &clip, &channels);
  ReadMotion(in, tokens, path, channels, units_to_metres, &clip);
  return clip;
}

}  // namespace polyfit
