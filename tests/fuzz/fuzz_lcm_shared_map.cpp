// Another vehicle's obstacle_map_t bytes as they arrive from the bus, through the
// checks and the change of frame into the feature map.
#include "hal/lcm/lcm_shared_maps.hpp"
#include "zonemap/features/feature_map.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const zonemap::lcm_link::SharedMapsConfig config = [] {
    zonemap::lcm_link::SharedMapsConfig c;
    c.vehicle = "fuzz";
    c.world_origin = {48.1, 11.5, 520.0};
    c.max_boxes = 64;
    return c;
  }();
  static zonemap::lcm_link::SharedMapDecoder decoder(config);
  static zonemap::SharedMapInbox inbox(config.max_boxes);
  static zonemap::FeatureMap features(zonemap::MapConfig{}, true);
  zonemap::SharedMapUpdate* update = inbox.take_free();
  if (update == nullptr) return 0;
  update->source = 1;
  if (decoder.decode(data, size, update, 0.0)) {
    inbox.post(update);
    update = inbox.next();
    features.replace_shared(1, update->min, update->max, update->count);
  }
  inbox.release(update);
  return 0;
}
