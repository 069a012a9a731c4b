// A generated flight mapped through the threaded pipeline, as the tests set it up:
// the posts flight, its mapper and feature map, and hooks that note what was mapped.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hal/config/yaml_config.hpp"
#include "hal/replay/sequence.hpp"
#include "runtime/pipeline.hpp"
#include "test_support.hpp"
#include "zonemap/features/feature_map.hpp"
#include "zonemap/mapping/mapper.hpp"

namespace zonemap::testing {

struct RecordingHooks : runtime::MappingHooks {
  std::vector<std::size_t> mapped;  // reserved: the mapping thread must not allocate
  Mapper* mapper = nullptr;
  FeatureMap* features = nullptr;
  void after_frame(std::size_t index, const Eigen::Isometry3d&, const FrameReport&,
                   double) override {
    if (mapped.size() < mapped.capacity()) mapped.push_back(index);
    // Extraction: the pipeline's own thread (the feature map is not ours to touch here).
  }
};

// A generated flight loaded for the runtime: its config, sequence, mapper and
// the feature map observing the mapper's zones.
struct MappedSequence {
  TempDir dir;
  MapConfig config;
  replay::ReplaySequence sequence;
  std::unique_ptr<Mapper> mapper;
  std::unique_ptr<FeatureMap> features;

  MappedSequence(const std::string& scenario, double rate_hz, int pixel_step, std::size_t frames) {
    const std::string path =
        write_test_scenario(scenario, dir / "seq", rate_hz, pixel_step, frames);
    std::string error;
    EXPECT_TRUE(hal::load_map_config(path, &config, &error)) << error;
    EXPECT_TRUE(sequence.open(dir / "seq", "", config, &error)) << error;
    mapper = std::make_unique<Mapper>(config, sequence.camera());
    features = std::make_unique<FeatureMap>(config, true);
    mapper->zones().add_observer(features.get());
  }
};

// The posts flight with hooks that note what was mapped.
struct Flight : MappedSequence {
  RecordingHooks hooks;

  explicit Flight(std::size_t frames)
      : MappedSequence("posts-through", 4.0, kRuntimePixelStep, frames) {
    hooks.mapped.reserve(frames);
    hooks.mapper = mapper.get();
    hooks.features = features.get();
  }

  runtime::PipelineStats run(hal::FrameSource& frames, hal::PoseSource* ins,
                             std::span<hal::ObstacleSink* const> sinks, bool lossless = true,
                             SharedMapInbox* shared_maps = nullptr) {
    runtime::PipelineOptions options;
    options.lossless = lossless;
    options.shared_maps = shared_maps;
    options.publish_every_frames = 1;
    options.pose_wait_s = 0.02;
    runtime::Pipeline pipeline(frames, ins == nullptr ? &sequence.poses() : nullptr, ins, sinks,
                               *mapper, *features, hooks, options);
    pipeline.run();
    return pipeline.stats();
  }
  std::vector<ObstacleBox> boxes() {
    std::vector<ObstacleBox> out(features->capacity());
    out.resize(features->merged(out.data(), out.size(), true));
    return out;
  }
};

}  // namespace zonemap::testing
