// The daemon's vehicle.yaml, from memory through the same parser the file loader uses.
#include "onboard/vehicle_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  zonemap::onboard::VehicleConfig config;
  std::string error;
  zonemap::onboard::load_vehicle_config_text(std::string(reinterpret_cast<const char*>(data), size),
                                             "fuzz.yaml", &config, &error);
  return 0;
}
