// Loading of the mapping configuration (config/*.yaml; its `pipeline:` section is the
// runtime's, runtime/runtime_config) and of camera.yaml
// (FORMATS.md §1). Strict: an unknown key, a wrong type or an out-of-range value
// is an error that names the file and line.
#pragma once

#include <string>

#include "zonemap/common/camera.hpp"
#include "zonemap/common/config.hpp"

namespace zonemap::hal {

bool load_map_config(const std::string& path, MapConfig* config, std::string* error);
bool load_camera_yaml(const std::string& path, CameraModel* camera, std::string* error);
// The same from text (`name` stands for the file in messages): tests, fuzzing.
bool load_map_config_text(const std::string& text, const std::string& name, MapConfig* config,
                          std::string* error);
bool load_camera_yaml_text(const std::string& text, const std::string& name, CameraModel* camera,
                           std::string* error);

// Checks a camera model's values (sizes within the build maxima, positive focal
// lengths, baseline, sigma and depth scale). Empty string when usable.
std::string validate_camera(const CameraModel& camera);

}  // namespace zonemap::hal
