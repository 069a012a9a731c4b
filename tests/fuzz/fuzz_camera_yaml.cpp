// camera.yaml: strict loader, every error a message, never a crash or an exception out.
#include "hal/replay/yaml_config.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = zonemap::fuzz::write_scratch(data, size, ".yaml");
  zonemap::CameraModel camera;
  std::string error;
  zonemap::hal::load_camera_yaml(path, &camera, &error);
  return 0;
}
