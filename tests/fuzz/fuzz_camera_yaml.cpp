// camera.yaml: strict loader, every error a message, never a crash or an exception
// out; from memory through the same parser the file loader uses.
#include "hal/config/yaml_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  zonemap::CameraModel camera;
  std::string error;
  zonemap::hal::load_camera_yaml_text(std::string(reinterpret_cast<const char*>(data), size),
                                      "fuzz.yaml", &camera, &error);
  return 0;
}
