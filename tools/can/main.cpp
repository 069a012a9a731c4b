// zonemap-can: the CAN layouts and logs from the command line.
//   zonemap-can dbc sbg-le|sbg-be|zonemap-ins|obstacles   print the layout as a DBC file
//   zonemap-can decode sbg-le|sbg-be|zonemap-ins LOG       INS solutions in a candump log
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>

#include "hal/can/candump.hpp"
#include "hal/can/dbc.hpp"
#include "hal/can/ins_can.hpp"
#include "hal/can/obstacle_can.hpp"
#include "zonemap/pose/ins_gate.hpp"

namespace {

int usage() {
  std::cerr << "usage: zonemap-can dbc sbg-le|sbg-be|zonemap-ins|obstacles\n"
               "       zonemap-can decode sbg-le|sbg-be|zonemap-ins CANDUMP_LOG\n";
  return 2;
}

bool profile_config(const std::string& name, zonemap::can::InsCanConfig* config) {
  using zonemap::can::InsCanProfile;
  if (name == "sbg-le" || name == "sbg-be") {
    config->profile = InsCanProfile::kSbgEcan;
    config->little_endian = name == "sbg-le";
  } else if (name == "zonemap-ins") {
    config->profile = InsCanProfile::kZonemapIns;
  } else {
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace zonemap::can;
  if (argc < 3) return usage();
  const std::string command = argv[1], profile = argv[2];
  if (command == "dbc") {
    if (profile == "sbg-le" || profile == "sbg-be") {
      const bool little = profile == "sbg-le";
      write_dbc(std::cout,
                little ? "SBG ECAN EKF messages, Intel (little-endian) byte order. zonemap decodes "
                         "INFO+QUAT+POS+ALTITUDE as one solution; POS_ACC adds the accuracy."
                       : "SBG ECAN EKF messages, Motorola (big-endian) byte order. zonemap decodes "
                         "INFO+QUAT+POS+ALTITUDE as one solution; POS_ACC adds the accuracy.",
                "INS", sbg_messages(little));
    } else if (profile == "zonemap-ins") {
      write_dbc(std::cout,
                "zonemap INS profile: one solution = TIME, POS_NE, POS_D, ATT with the same "
                "SEQUENCE; position local NED (mm), attitude body to NED (unit quaternion).",
                "INS", zonemap_ins_messages());
    } else if (profile == "obstacles") {
      write_dbc(std::cout,
                "zonemap obstacle boxes: BEGIN, BOX_MIN+BOX_MAX per box (nearest first; "
                "BOX_AGE after them when the box was last seen over 1 s ago, or comes from a prior "
                "map no view has confirmed: PRIOR = 1), END with the same "
                "GENERATION. Corners in the map's world frame relative to ANCHOR (dm); END FLAGS "
                "bit 0 cut short, bit 1 some out of range, bit 2 world z down (NED; clear: z up). "
                "No camera mount enters the boxes.",
                "ZONEMAP", obstacle_messages());
    } else {
      return usage();
    }
    return 0;
  }
  if (command == "decode" && argc == 4) {
    InsCanConfig config;
    if (!profile_config(profile, &config)) return usage();
    std::ifstream in(argv[3]);
    if (!in) {
      std::cerr << argv[3] << ": cannot open\n";
      return 1;
    }
    InsCanDecoder decoder(config);
    zonemap::InsGate gate;
    std::string line;
    int number = 0, malformed = 0;
    while (std::getline(in, line)) {
      ++number;
      CanFrame frame;
      const char* why = nullptr;
      const CandumpLine kind = parse_candump_line(line, &frame, nullptr, &why);
      if (kind == CandumpLine::kMalformed) {
        std::cerr << argv[3] << ":" << number << ": " << why << "\n";
        ++malformed;
        continue;
      }
      if (kind != CandumpLine::kFrame) continue;
      zonemap::InsSolution s;
      if (!decoder.feed(frame, &s)) continue;
      zonemap::InsRejection reason{};
      if (!gate.check(s, &reason)) {
        std::cerr << argv[3] << ":" << number << ": solution refused: " << to_string(reason)
                  << "\n";
        continue;
      }
      std::printf("%.6f %.3f %.3f %.3f %.6f %.6f %.6f %.6f\n", s.time_s, s.position_m.x(),
                  s.position_m.y(), s.position_m.z(), s.attitude.x(), s.attitude.y(),
                  s.attitude.z(), s.attitude.w());
    }
    const InsCanCounters& c = decoder.counters();
    std::cerr << "frames " << c.frames << ", solutions " << c.solutions << ", accepted "
              << gate.counters().accepted << ", refused " << gate.counters().rejected_total()
              << ", malformed lines " << malformed << ", ignored id " << c.ignored_id
              << ", bad dlc " << c.bad_dlc << ", orphan parts " << c.orphan_parts << ", incomplete "
              << c.incomplete_sets << ", mixed " << c.mixed_sets << "\n";
    return 0;
  }
  return usage();
}
