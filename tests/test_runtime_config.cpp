// The runtime's part of a configuration file: the `pipeline:` section read into
// PipelineOptions (runtime/runtime_config), strict, and skipped by the mapping loader.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hal/config/yaml_config.hpp"
#include "runtime/runtime_config.hpp"
#include "test_support.hpp"

using namespace zonemap;

TEST(RuntimeConfig, ShippedConfigsGiveTheirPipelineSection) {
  for (const char* name : {"outdoor-0.5m", "paper-flight1", "paper-flight2", "paper-flight3",
                           "indoor-kinect", "euroc-mav", "tum-rgbd"}) {
    const std::string path = zonemap::testing::source_path(std::string("config/") + name + ".yaml");
    runtime::PipelineOptions options;
    std::string error;
    EXPECT_TRUE(runtime::load_pipeline_options(path, &options, &error)) << name << ": " << error;
    MapConfig map;
    EXPECT_TRUE(hal::load_map_config(path, &map, &error)) << name << ": " << error;
  }
  runtime::PipelineOptions flight2;
  flight2.frame_period_s = 1.0;  // overwritten by the file
  std::string error;
  ASSERT_TRUE(runtime::load_pipeline_options(
      zonemap::testing::source_path("config/paper-flight2.yaml"), &flight2, &error))
      << error;
  EXPECT_DOUBLE_EQ(flight2.frame_period_s, 0.0333);
  EXPECT_EQ(flight2.publish_every_frames, 3);
  EXPECT_EQ(flight2.cpu_mapping, -1);
}

TEST(RuntimeConfig, NoSectionKeepsTheDefaultsAndTheProgramsFields) {
  runtime::PipelineOptions options;
  options.lossless = false;  // a program's field, not the file's
  std::string error;
  ASSERT_TRUE(
      runtime::load_pipeline_options_text("map:\n  cell_size_m: 1.0\n", "x.yaml", &options, &error))
      << error;
  EXPECT_FALSE(options.lossless);
  EXPECT_EQ(options.publish_every_frames, runtime::PipelineOptions{}.publish_every_frames);
  ASSERT_TRUE(runtime::load_pipeline_options_text(
      "pipeline:\n  priority_ins: 40\n  cpu_ins: 2\n  publish_every_frames: 5\n", "x.yaml",
      &options, &error))
      << error;
  EXPECT_EQ(options.priority_ins, 40);
  EXPECT_EQ(options.cpu_ins, 2);
  EXPECT_EQ(options.publish_every_frames, 5);
  ASSERT_TRUE(runtime::load_pipeline_options_text(
      "pipeline:\n  mapping_workers: 3\n  cpu_workers: [2, 3]\n", "x.yaml", &options, &error))
      << error;
  EXPECT_EQ(options.mapping_workers, 3);
  EXPECT_EQ(options.cpu_workers, (std::vector<int>{2, 3}));
}

TEST(RuntimeConfig, MappingWorkersAndTheirCpusAreChecked) {
  runtime::PipelineOptions options;
  std::string error;
  EXPECT_FALSE(runtime::load_pipeline_options_text("pipeline:\n  mapping_workers: 0\n", "x.yaml",
                                                   &options, &error));
  EXPECT_NE(error.find("x.yaml: pipeline.mapping_workers must be in [1, 8]"), std::string::npos)
      << error;
  EXPECT_FALSE(runtime::load_pipeline_options_text("pipeline:\n  mapping_workers: 9\n", "x.yaml",
                                                   &options, &error));
  EXPECT_FALSE(runtime::load_pipeline_options_text(
      "pipeline:\n  mapping_workers: 2\n  cpu_workers: [1, 2]\n", "x.yaml", &options, &error));
  EXPECT_NE(error.find("more CPUs than there are workers"), std::string::npos) << error;
  EXPECT_FALSE(runtime::load_pipeline_options_text(
      "pipeline:\n  mapping_workers: 2\n  cpu_workers: [4096]\n", "x.yaml", &options, &error));
  EXPECT_NE(error.find("cpu_workers must each be in [-1, 1023]"), std::string::npos) << error;
  EXPECT_FALSE(runtime::load_pipeline_options_text(
      "pipeline:\n  mapping_workers: 2\n  cpu_workers: 1\n", "x.yaml", &options, &error));
  EXPECT_NE(error.find("x.yaml:3: bad value for 'cpu_workers'"), std::string::npos) << error;
  EXPECT_EQ(options.mapping_workers, 1) << "a refused section changes nothing";
}

TEST(RuntimeConfig, AWrongKeyOrValueNamesFileAndLine) {
  runtime::PipelineOptions options;
  std::string error;
  EXPECT_FALSE(runtime::load_pipeline_options_text("pipeline:\n  priority_maping: 80\n", "x.yaml",
                                                   &options, &error));
  EXPECT_NE(error.find("x.yaml:2: unknown key 'priority_maping' in 'pipeline'"), std::string::npos)
      << error;
  EXPECT_FALSE(runtime::load_pipeline_options_text("pipeline:\n  priority_mapping: 100\n", "x.yaml",
                                                   &options, &error));
  EXPECT_NE(error.find("x.yaml: pipeline priorities must be in [0, 99]"), std::string::npos)
      << error;
  EXPECT_FALSE(runtime::load_pipeline_options_text("pipeline:\n  cpu_ins: -2\n", "x.yaml", &options,
                                                   &error));
  EXPECT_FALSE(runtime::load_pipeline_options_text("pipeline:\n  pose_wait_s: fast\n", "x.yaml",
                                                   &options, &error));
  EXPECT_NE(error.find("x.yaml:2: bad value for 'pose_wait_s'"), std::string::npos) << error;
  EXPECT_EQ(options.pose_wait_s, runtime::PipelineOptions{}.pose_wait_s);  // left as it was
  // The mapping loader leaves the section to the runtime.
  MapConfig map;
  EXPECT_TRUE(
      hal::load_map_config_text("pipeline:\n  priority_maping: 80\n", "x.yaml", &map, &error))
      << error;
}
