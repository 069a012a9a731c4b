// LCM ins_state_t bytes as they arrive from the bus, through decoding and the gate.
#include "hal/lcm/lcm_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static zonemap::InsGate gate;
  zonemap::InsSolution s;
  for (const bool z_up : {false, true}) {
    if (zonemap::lcm_link::decode_ins_state(data, size, z_up, &s) ==
        zonemap::lcm_link::InsDecode::kOk) {
      zonemap::InsRejection why{};
      if (gate.check(s, &why)) zonemap::camera_pose_sample(s, Eigen::Isometry3d::Identity());
    }
  }
  return 0;
}
