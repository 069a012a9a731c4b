// The mapping configuration (config/*.yaml): strict loader plus validation.
#include "hal/replay/yaml_config.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = zonemap::fuzz::write_scratch(data, size, ".yaml");
  zonemap::MapConfig config;
  std::string error;
  zonemap::hal::load_map_config(path, &config, &error);
  return 0;
}
