#include "onboard/vehicle_config.hpp"

#include <filesystem>

#include "hal/config/yaml_support.hpp"

namespace zonemap::onboard {
namespace {

using hal::ParseError;
using hal::Reader;
using hal::where;

std::string relative_to(const std::string& file, const std::string& path) {
  if (path.empty() || std::filesystem::path(path).is_absolute()) return path;
  return (std::filesystem::path(file).parent_path() / path).lexically_normal().string();
}

template <typename T>
Reader into(T* target) {
  return [target](const YAML::Node& node) { *target = node.as<T>(); };
}

Reader one_of(const std::string& path, const std::string& key,
              std::map<std::string, std::function<void()>> choices) {
  return [path, key, choices](const YAML::Node& node) {
    const std::string value = node.as<std::string>();
    const auto it = choices.find(value);
    if (it == choices.end()) {
      std::string names;
      for (const auto& c : choices) names += (names.empty() ? "" : ", ") + c.first;
      throw ParseError{where(path, node) + ": " + key + " must be one of: " + names};
    }
    it->second();
  };
}

Reader can_id(std::uint32_t* target) {
  return [target](const YAML::Node& node) {
    const auto value = node.as<std::uint64_t>();  // YAML reads 0x130 as hex
    if (value > 0x1FFFFFFFu) throw YAML::Exception(node.Mark(), "CAN ID out of range");
    *target = static_cast<std::uint32_t>(value);
  };
}

}  // namespace

static bool parse_vehicle_config(const YAML::Node& root, const std::string& path,
                                 VehicleConfig* out, std::string* error) {
  VehicleConfig c;
  c.path = path;
  try {
    auto section = [&](const std::string& name, std::map<std::string, Reader> readers) {
      return [&path, name, readers](const YAML::Node& node) {
        hal::read_section(path, node, name, readers);
      };
    };
    auto origin = [&](const YAML::Node& node) {
      if (node.IsScalar() && node.as<std::string>() == "first_fix") {
        c.can_profile.has_origin = false;
        return;
      }
      if (!node.IsSequence() || node.size() != 3) {
        throw ParseError{where(path, node) + ": origin must be first_fix or [lat, lon, height]"};
      }
      c.can_profile.has_origin = true;
      c.can_profile.origin = {node[0].as<double>(), node[1].as<double>(), node[2].as<double>()};
    };
    hal::read_section(
        path, root, "",
        {{"mapping", into(&c.mapping_path)},
         {"camera", into(&c.camera_path)},
         {"live", into(&c.live)},
         {"frames",
          section("frames",
                  {{"source", one_of(path, "frames.source",
                                     {{"replay", [&] { c.frames = VehicleConfig::FrameSourceKind::kReplay; }},
                                      {"v4l2", [&] { c.frames = VehicleConfig::FrameSourceKind::kV4l2; }}})},
                   {"sequence", into(&c.sequence_dir)},
                   {"rate_hz", into(&c.replay_rate_hz)},
                   {"device", into(&c.v4l2_device)},
                   {"pixel_format", one_of(path, "frames.pixel_format",
                                           {{"Y16", [&] { c.v4l2_format = "Y16"; }},
                                            {"Z16", [&] { c.v4l2_format = "Z16"; }}})}})},
         {"poses",
          section("poses",
                  {{"source",
                    one_of(path, "poses.source",
                           {{"sequence", [&] { c.poses = VehicleConfig::PoseSourceKind::kSequence; }},
                            {"lcm", [&] { c.poses = VehicleConfig::PoseSourceKind::kLcm; }},
                            {"lcm_log", [&] { c.poses = VehicleConfig::PoseSourceKind::kLcmLog; }},
                            {"can", [&] { c.poses = VehicleConfig::PoseSourceKind::kCan; }},
                            {"candump", [&] { c.poses = VehicleConfig::PoseSourceKind::kCandump; }}})},
                   {"lcm_url", into(&c.lcm_url)},
                   {"lcm_channel", into(&c.lcm_channel)},
                   {"log", into(&c.pose_log_path)},
                   {"can_interface", into(&c.can_interface)},
                   {"can_profile",
                    one_of(path, "poses.can_profile",
                           {{"sbg-ecan", [&] { c.can_profile.profile = can::InsCanProfile::kSbgEcan; }},
                            {"zonemap-ins",
                             [&] { c.can_profile.profile = can::InsCanProfile::kZonemapIns; }}})},
                   {"byte_order", one_of(path, "poses.byte_order",
                                         {{"little", [&] { c.can_profile.little_endian = true; }},
                                          {"big", [&] { c.can_profile.little_endian = false; }}})},
                   {"extended_ids", into(&c.can_profile.extended_ids)},
                   {"ids", section("poses.ids", {{"info", can_id(&c.can_profile.id_info)},
                                                 {"quat", can_id(&c.can_profile.id_quat)},
                                                 {"pos", can_id(&c.can_profile.id_pos)},
                                                 {"altitude", can_id(&c.can_profile.id_altitude)},
                                                 {"pos_acc", can_id(&c.can_profile.id_pos_acc)},
                                                 {"base", can_id(&c.can_profile.base_id)}})},
                   {"origin", origin},
                   {"time_source",
                    one_of(path, "poses.time_source",
                           {{"receive", [&] { c.can_profile.time_source = can::InsTimeSource::kReceive; }},
                            {"ins", [&] { c.can_profile.time_source = can::InsTimeSource::kIns; }}})},
                   {"time_offset_s", into(&c.time_offset_s)},
                   {"max_speed_mps", into(&c.gate.max_speed_mps)},
                   {"jump_margin_m", into(&c.gate.jump_margin_m)},
                   {"max_position_sigma_m", into(&c.gate.max_position_sigma_m)},
                   {"reanchor_after_s", into(&c.gate.reanchor_after_s)}})},
         {"outputs",
          section("outputs",
                  {{"directory", into(&c.output_dir)},
                   {"health_period_s", into(&c.health_period_s)},
                   {"record", [&](const YAML::Node& node) {
                      hal::read_section(path, node, "outputs.record",
                                        {{"path", into(&c.record_path)},
                                         {"depth_every", into(&c.record_depth_every)}});
                    }},
                   {"can", [&](const YAML::Node& node) {
                      c.can_output = true;
                      hal::read_section(path, node, "outputs.can",
                                        {{"interface", into(&c.can_output_interface)},
                                         {"base_id", can_id(&c.can_obstacles.base_id)},
                                         {"extended_ids", into(&c.can_obstacles.extended_ids)},
                                         {"rate_hz", into(&c.can_obstacles.rate_hz)},
                                         {"max_frames_per_s", into(&c.can_obstacles.max_frames_per_s)},
                                         {"include_ground", into(&c.can_obstacles.include_ground)}});
                    }},
                   {"lcm", [&](const YAML::Node& node) {
                      c.lcm_output = true;
                      hal::read_section(path, node, "outputs.lcm",
                                        {{"url", into(&c.lcm.url)},
                                         {"map_channel", into(&c.lcm.map_channel)},
                                         {"distance_channel", into(&c.lcm.distance_channel)},
                                         {"health_channel", into(&c.lcm.health_channel)},
                                         {"rate_hz", into(&c.lcm.rate_hz)},
                                         {"max_boxes", into(&c.lcm.max_boxes)}});
                    }},
                   {"mavlink", [&](const YAML::Node& node) {
                      c.mavlink_output = true;
                      hal::read_section(path, node, "outputs.mavlink",
                                        {{"host", into(&c.mavlink.host)},
                                         {"port", into(&c.mavlink.port)},
                                         {"rate_hz", into(&c.mavlink.rate_hz)},
                                         {"system_id", into(&c.mavlink.system_id)},
                                         {"component_id", into(&c.mavlink.component_id)},
                                         {"obstacles_3d", into(&c.mavlink.max_obstacles_3d)},
                                         {"stale_after_s", into(&c.mavlink.stale_after_s)}});
                    }}})}});
  } catch (const ParseError& e) {
    *error = e.message;
    return false;
  } catch (const YAML::Exception& e) {
    *error = path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
    return false;
  }
  // What must be there for the chosen sources.
  const auto need = [&](bool ok, const char* what) {
    if (!ok) *error = path + ": " + what;
    return ok;
  };
  if (!need(!c.mapping_path.empty(), "'mapping:' (the mapping configuration) is required")) {
    return false;
  }
  if (c.frames == VehicleConfig::FrameSourceKind::kReplay &&
      !need(!c.sequence_dir.empty(), "frames.source replay needs frames.sequence")) {
    return false;
  }
  if (c.frames == VehicleConfig::FrameSourceKind::kV4l2 &&
      !need(!c.camera_path.empty(), "frames.source v4l2 needs 'camera:' (camera.yaml)")) {
    return false;
  }
  if ((c.poses == VehicleConfig::PoseSourceKind::kLcmLog ||
       c.poses == VehicleConfig::PoseSourceKind::kCandump) &&
      !need(!c.pose_log_path.empty(), "poses.source lcm_log / candump needs poses.log")) {
    return false;
  }
  if (c.poses == VehicleConfig::PoseSourceKind::kSequence &&
      !need(c.frames == VehicleConfig::FrameSourceKind::kReplay,
            "poses.source sequence needs frames.source replay")) {
    return false;
  }
  if (!need(c.health_period_s > 0.0 && c.can_obstacles.rate_hz > 0.0 && c.lcm.rate_hz > 0.0 &&
                c.mavlink.rate_hz > 0.0,
            "rates and periods must be positive")) {
    return false;
  }
  if (!need(c.record_depth_every >= 0, "outputs.record.depth_every must be >= 0")) return false;
  if (c.mavlink_output) {
    const std::string why = mavlink::validate(c.mavlink);
    if (!need(why.empty(), why.c_str())) return false;
  }
  c.mapping_path = relative_to(path, c.mapping_path);
  c.camera_path = relative_to(path, c.camera_path);
  c.sequence_dir = relative_to(path, c.sequence_dir);
  c.pose_log_path = relative_to(path, c.pose_log_path);
  c.output_dir = relative_to(path, c.output_dir);
  c.record_path = relative_to(path, c.record_path);
  *out = c;
  return true;
}

bool load_vehicle_config(const std::string& path, VehicleConfig* out, std::string* error) {
  YAML::Node root;
  return hal::load_file(path, &root, error) && parse_vehicle_config(root, path, out, error);
}

bool load_vehicle_config_text(const std::string& text, const std::string& name, VehicleConfig* out,
                              std::string* error) {
  YAML::Node root;
  return hal::load_text(text, name, &root, error) && parse_vehicle_config(root, name, out, error);
}

}  // namespace zonemap::onboard
