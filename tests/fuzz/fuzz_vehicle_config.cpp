// The daemon's vehicle.yaml.
#include "tests/fuzz/fuzz_support.hpp"
#include "tools/daemon/vehicle_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = zonemap::fuzz::write_scratch(data, size, ".yaml");
  zonemap::daemon::VehicleConfig config;
  std::string error;
  zonemap::daemon::load_vehicle_config(path, &config, &error);
  return 0;
}
