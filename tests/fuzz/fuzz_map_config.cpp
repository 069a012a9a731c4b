// The mapping configuration (config/*.yaml): strict loader plus validation, from
// memory through the same parsers the file loaders use (the mapping sections, and
// the runtime's `pipeline:` section).
#include "hal/config/yaml_config.hpp"
#include "runtime/runtime_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  zonemap::MapConfig config;
  std::string error;
  zonemap::hal::load_map_config_text(text, "fuzz.yaml", &config, &error);
  zonemap::runtime::PipelineOptions options;
  zonemap::runtime::load_pipeline_options_text(text, "fuzz.yaml", &options, &error);
  return 0;
}
