#include "onboard/vehicle_config.hpp"

#include <cmath>
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

using hal::into;
using Frames = VehicleConfig::FrameSourceKind;
using Poses = VehicleConfig::PoseSourceKind;

Reader frames_section(const std::string& path, VehicleConfig* c) {
  return [path, c](const YAML::Node& node) {
    hal::read_section(path, node, "frames",
                      {{"source", one_of(path, "frames.source",
                                         {{"replay", [c] { c->frames = Frames::kReplay; }},
                                          {"v4l2", [c] { c->frames = Frames::kV4l2; }}})},
                       {"sequence", into(&c->sequence_dir)},
                       {"rate_hz", into(&c->replay_rate_hz)},
                       {"device", into(&c->v4l2_device)},
                       {"pixel_format", one_of(path, "frames.pixel_format",
                                               {{"Y16", [c] { c->v4l2_format = "Y16"; }},
                                                {"Z16", [c] { c->v4l2_format = "Z16"; }}})}});
  };
}

// first_fix, or [lat, lon, height] of the local frame's origin.
Reader can_origin(const std::string& path, can::InsCanConfig* profile) {
  return [path, profile](const YAML::Node& node) {
    if (node.IsScalar() && node.as<std::string>() == "first_fix") {
      profile->has_origin = false;
      return;
    }
    if (!node.IsSequence() || node.size() != 3) {
      throw ParseError{where(path, node) + ": origin must be first_fix or [lat, lon, height]"};
    }
    profile->has_origin = true;
    profile->origin = {node[0].as<double>(), node[1].as<double>(), node[2].as<double>()};
  };
}

Reader world_origin(const std::string& path, VehicleConfig* c) {
  return [path, c](const YAML::Node& node) {
    if (!node.IsSequence() || node.size() != 3) {
      throw ParseError{where(path, node) + ": world_origin must be [latitude, longitude, height]"};
    }
    const Geodetic o{node[0].as<double>(), node[1].as<double>(), node[2].as<double>()};
    if (!(std::abs(o.latitude_deg) <= 90.0 && std::abs(o.longitude_deg) <= 180.0 &&
          std::abs(o.height_m) <= 1.0e5)) {
      throw ParseError{where(path, node) + ": world_origin is not a WGS84 position"};
    }
    c->has_world_origin = true;
    c->world_origin = o;
  };
}

Reader vehicle_name(VehicleConfig* c) {
  return [c](const YAML::Node& node) {
    c->vehicle = node.as<std::string>();
    c->vehicle_named = true;
  };
}

// shared_maps: another vehicle's obstacle_map_t channels (one sender each).
Reader shared_maps_section(const std::string& path, VehicleConfig* c) {
  return [path, c](const YAML::Node& node) {
    c->shared_maps = true;
    hal::read_section(path, node, "shared_maps",
                      {{"url", into(&c->shared.url)},
                       {"channels", into(&c->shared.channels)},
                       {"max_boxes", into(&c->shared.max_boxes)}});
  };
}

Reader can_profile_keys(const std::string& path, can::InsCanConfig* p) {
  return [path, p](const YAML::Node& node) {
    hal::read_section(path, node, "poses.ids",
                      {{"info", can_id(&p->id_info)},
                       {"quat", can_id(&p->id_quat)},
                       {"pos", can_id(&p->id_pos)},
                       {"altitude", can_id(&p->id_altitude)},
                       {"pos_acc", can_id(&p->id_pos_acc)},
                       {"base", can_id(&p->base_id)}});
  };
}

Reader poses_section(const std::string& path, VehicleConfig* c) {
  return [path, c](const YAML::Node& node) {
    can::InsCanConfig* p = &c->can_profile;
    hal::read_section(
        path, node, "poses",
        {{"source", one_of(path, "poses.source",
                           {{"sequence", [c] { c->poses = Poses::kSequence; }},
                            {"lcm", [c] { c->poses = Poses::kLcm; }},
                            {"lcm_log", [c] { c->poses = Poses::kLcmLog; }},
                            {"can", [c] { c->poses = Poses::kCan; }},
                            {"candump", [c] { c->poses = Poses::kCandump; }},
                            {"mavlink", [c] { c->poses = Poses::kMavlink; }}})},
         {"mavlink_listen", into(&c->mavlink_poses.listen)},
         {"autopilot_system_id", into(&c->mavlink_poses.autopilot_system_id)},
         {"rate_hz", into(&c->mavlink_poses.rate_hz)},
         {"lcm_url", into(&c->lcm_url)},
         {"lcm_channel", into(&c->lcm_channel)},
         {"log", into(&c->pose_log_path)},
         {"can_interface", into(&c->can_interface)},
         {"can_profile",
          one_of(path, "poses.can_profile",
                 {{"sbg-ecan", [p] { p->profile = can::InsCanProfile::kSbgEcan; }},
                  {"zonemap-ins", [p] { p->profile = can::InsCanProfile::kZonemapIns; }}})},
         {"byte_order", one_of(path, "poses.byte_order",
                               {{"little", [p] { p->little_endian = true; }},
                                {"big", [p] { p->little_endian = false; }}})},
         {"extended_ids", into(&p->extended_ids)},
         {"ids", can_profile_keys(path, p)},
         {"origin", can_origin(path, p)},
         {"time_source",
          one_of(path, "poses.time_source",
                 {{"receive", [p] { p->time_source = can::InsTimeSource::kReceive; }},
                  {"ins", [p] { p->time_source = can::InsTimeSource::kIns; }}})},
         {"time_offset_s", into(&c->time_offset_s)},
         {"max_speed_mps", into(&c->gate.max_speed_mps)},
         {"jump_margin_m", into(&c->gate.jump_margin_m)},
         {"max_position_sigma_m", into(&c->gate.max_position_sigma_m)},
         {"reanchor_after_s", into(&c->gate.reanchor_after_s)}});
  };
}

// outputs.can, .lcm, .mavlink: each present section switches its link on.
Reader can_output(const std::string& path, VehicleConfig* c) {
  return [path, c](const YAML::Node& node) {
    c->can_output = true;
    hal::read_section(path, node, "outputs.can",
                      {{"interface", into(&c->can_output_interface)},
                       {"base_id", can_id(&c->can_obstacles.base_id)},
                       {"extended_ids", into(&c->can_obstacles.extended_ids)},
                       {"rate_hz", into(&c->can_obstacles.rate_hz)},
                       {"max_frames_per_s", into(&c->can_obstacles.max_frames_per_s)},
                       {"include_ground", into(&c->can_obstacles.include_ground)}});
  };
}
Reader lcm_output(const std::string& path, VehicleConfig* c) {
  return [path, c](const YAML::Node& node) {
    c->lcm_output = true;
    hal::read_section(path, node, "outputs.lcm",
                      {{"url", into(&c->lcm.url)},
                       {"map_channel", into(&c->lcm.map_channel)},
                       {"distance_channel", into(&c->lcm.distance_channel)},
                       {"health_channel", into(&c->lcm.health_channel)},
                       {"rate_hz", into(&c->lcm.rate_hz)},
                       {"max_boxes", into(&c->lcm.max_boxes)}});
  };
}
Reader mavlink_output(const std::string& path, VehicleConfig* c) {
  return [path, c](const YAML::Node& node) {
    c->mavlink_output = true;
    hal::read_section(path, node, "outputs.mavlink",
                      {{"autopilot", into(&c->mavlink.autopilot)},
                       {"messages", into(&c->mavlink.messages)},
                       {"host", into(&c->mavlink.host)},
                       {"port", into(&c->mavlink.port)},
                       {"rate_hz", into(&c->mavlink.rate_hz)},
                       {"system_id", into(&c->mavlink.system_id)},
                       {"component_id", into(&c->mavlink.component_id)},
                       {"obstacles_3d", into(&c->mavlink.max_obstacles_3d)},
                       {"stale_after_s", into(&c->mavlink.stale_after_s)}});
  };
}

Reader outputs_section(const std::string& path, VehicleConfig* c) {
  return [path, c](const YAML::Node& node) {
    hal::read_section(path, node, "outputs",
                      {{"directory", into(&c->output_dir)},
                       {"health_period_s", into(&c->health_period_s)},
                       {"save_map_every_s", into(&c->save_map_every_s)},
                       {"record",
                        [path, c](const YAML::Node& record) {
                          hal::read_section(path, record, "outputs.record",
                                            {{"path", into(&c->record_path)},
                                             {"depth_every", into(&c->record_depth_every)}});
                        }},
                       {"can", can_output(path, c)},
                       {"lcm", lcm_output(path, c)},
                       {"mavlink", mavlink_output(path, c)}});
  };
}

// What the chosen sources and sinks need: empty when all is there.
std::string missing_for_sources(const VehicleConfig& c) {
  if (c.mapping_path.empty()) return "'mapping:' (the mapping configuration) is required";
  if (c.frames == Frames::kReplay && c.sequence_dir.empty()) {
    return "frames.source replay needs frames.sequence";
  }
  if (c.frames == Frames::kV4l2 && c.camera_path.empty()) {
    return "frames.source v4l2 needs 'camera:' (camera.yaml)";
  }
  if ((c.poses == Poses::kLcmLog || c.poses == Poses::kCandump) && c.pose_log_path.empty()) {
    return "poses.source lcm_log / candump needs poses.log";
  }
  if (c.poses == Poses::kSequence && c.frames != Frames::kReplay) {
    return "poses.source sequence needs frames.source replay";
  }
  if (!(c.health_period_s > 0.0 && c.can_obstacles.rate_hz > 0.0 && c.lcm.rate_hz > 0.0 &&
        c.mavlink.rate_hz > 0.0)) {
    return "rates and periods must be positive";
  }
  if (c.record_depth_every < 0) return "outputs.record.depth_every must be >= 0";
  if (!(c.save_map_every_s >= 0.0)) return "outputs.save_map_every_s must be >= 0 (0: at stop)";
  if (c.save_map_every_s > 0.0 && c.output_dir.empty()) {
    return "outputs.save_map_every_s needs outputs.directory (the map goes to its boxes.csv)";
  }
  if (c.shared_maps) {
    if (!c.has_world_origin || !c.vehicle_named) {
      return "shared_maps needs this vehicle's 'vehicle:' name and 'world_origin:' (the maps "
             "meet through their origins)";
    }
    if (c.shared.channels.empty() || c.shared.channels.size() > 255) {
      return "shared_maps.channels must name 1 to 255 channels";
    }
    if (c.shared.max_boxes == 0 || c.shared.max_boxes > 65536) {
      return "shared_maps.max_boxes must be 1 to 65536";
    }
  }
  if (c.can_profile.has_origin && c.has_world_origin &&
      (c.can_profile.origin.latitude_deg != c.world_origin.latitude_deg ||
       c.can_profile.origin.longitude_deg != c.world_origin.longitude_deg ||
       c.can_profile.origin.height_m != c.world_origin.height_m)) {
    return "poses.origin and world_origin differ: the INS frame is the world frame";
  }
  if (c.poses == Poses::kMavlink) {
    const std::string why = mavlink::validate(c.mavlink_poses);
    if (!why.empty()) return why;
  }
  if (c.mavlink_output) return mavlink::validate(c.mavlink);
  return "";
}

// Paths in the file are relative to it.
void resolve_paths(const std::string& path, VehicleConfig* c) {
  for (std::string* p : {&c->mapping_path, &c->prior_path, &c->camera_path, &c->sequence_dir,
                         &c->pose_log_path, &c->output_dir, &c->record_path}) {
    *p = relative_to(path, *p);
  }
}

bool parse_vehicle_config(const YAML::Node& root, const std::string& path, VehicleConfig* out,
                          std::string* error) {
  VehicleConfig c;
  c.path = path;
  const bool read = hal::read_explained(path, error, [&] {
    hal::read_section(path, root, "",
                      {{"mapping", into(&c.mapping_path)},
                       {"prior", into(&c.prior_path)},
                       {"camera", into(&c.camera_path)},
                       {"live", into(&c.live)},
                       {"vehicle", vehicle_name(&c)},
                       {"world_origin", world_origin(path, &c)},
                       {"shared_maps", shared_maps_section(path, &c)},
                       {"frames", frames_section(path, &c)},
                       {"poses", poses_section(path, &c)},
                       {"outputs", outputs_section(path, &c)}});
  });
  if (!read) return false;
  const std::string missing = missing_for_sources(c);
  if (!missing.empty()) {
    *error = path + ": " + missing;
    return false;
  }
  resolve_paths(path, &c);
  // The INS frame's configured origin is the world frame's.
  if (!c.has_world_origin && c.poses == Poses::kCan && c.can_profile.has_origin) {
    c.has_world_origin = true;
    c.world_origin = c.can_profile.origin;
  }
  c.lcm.vehicle = c.shared.vehicle = c.vehicle;
  c.lcm.has_world_origin = c.has_world_origin;
  c.lcm.world_origin = c.shared.world_origin = c.world_origin;
  *out = c;
  return true;
}

}  // namespace

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
