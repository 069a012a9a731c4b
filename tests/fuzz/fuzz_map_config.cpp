// The mapping configuration (config/*.yaml): strict loader plus validation, from
// memory through the same parser the file loader uses.
#include "hal/replay/yaml_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  zonemap::MapConfig config;
  std::string error;
  zonemap::hal::load_map_config_text(std::string(reinterpret_cast<const char*>(data), size),
                                     "fuzz.yaml", &config, &error);
  return 0;
}
