#include "runtime/runtime_config.hpp"

#include <yaml-cpp/yaml.h>

#include <string>

#include "hal/config/yaml_support.hpp"
#include "zonemap/integrator/projective_integrator.hpp"

namespace zonemap::runtime {
namespace {

bool priority_ok(int priority) {
  return priority >= 0 && priority <= 99;
}
bool cpu_ok(int cpu) {
  return cpu >= -1 && cpu <= 1023;
}

bool parse_pipeline_section(const YAML::Node& root, const std::string& path,
                            PipelineOptions* options, std::string* error) {
  PipelineOptions o = *options;
  if (root.IsMap() && root["pipeline"]) {
    const bool read = hal::read_explained(path, error, [&] {
      hal::read_section(path, root["pipeline"], "pipeline",
                        {{"frame_period_s", hal::into(&o.frame_period_s)},
                         {"pose_wait_s", hal::into(&o.pose_wait_s)},
                         {"publish_every_frames", hal::into(&o.publish_every_frames)},
                         {"lock_memory", hal::into(&o.lock_memory)},
                         {"priority_acquisition", hal::into(&o.priority_acquisition)},
                         {"priority_mapping", hal::into(&o.priority_mapping)},
                         {"priority_output", hal::into(&o.priority_output)},
                         {"priority_extraction", hal::into(&o.priority_extraction)},
                         {"priority_ins", hal::into(&o.priority_ins)},
                         {"cpu_acquisition", hal::into(&o.cpu_acquisition)},
                         {"cpu_mapping", hal::into(&o.cpu_mapping)},
                         {"cpu_output", hal::into(&o.cpu_output)},
                         {"cpu_extraction", hal::into(&o.cpu_extraction)},
                         {"cpu_ins", hal::into(&o.cpu_ins)},
                         {"mapping_workers", hal::into(&o.mapping_workers)},
                         {"cpu_workers", hal::into(&o.cpu_workers)}});
    });
    if (!read) return false;
  }
  const std::string invalid = validate_pipeline_section(o);
  if (!invalid.empty()) {
    *error = path + ": " + invalid;
    return false;
  }
  *options = o;
  return true;
}

}  // namespace

std::string validate_pipeline_section(const PipelineOptions& o) {
  if (!(o.frame_period_s > 0.0) || !(o.pose_wait_s >= 0.0) || o.pose_wait_s > 1.0 ||
      o.publish_every_frames < 1) {
    return "pipeline.frame_period_s > 0, pipeline.pose_wait_s in [0, 1], "
           "pipeline.publish_every_frames >= 1";
  }
  const bool priorities_ok = priority_ok(o.priority_acquisition) &&
                             priority_ok(o.priority_mapping) && priority_ok(o.priority_output) &&
                             priority_ok(o.priority_extraction) && priority_ok(o.priority_ins);
  const bool cpus_ok = cpu_ok(o.cpu_acquisition) && cpu_ok(o.cpu_mapping) && cpu_ok(o.cpu_output) &&
                       cpu_ok(o.cpu_extraction) && cpu_ok(o.cpu_ins);
  if (!priorities_ok || !cpus_ok) {
    return "pipeline priorities must be in [0, 99] and cpus in [-1, 1023]";
  }
  if (o.mapping_workers < 1 || o.mapping_workers > ProjectiveIntegrator::kMaxParts) {
    return "pipeline.mapping_workers must be in [1, " +
           std::to_string(ProjectiveIntegrator::kMaxParts) + "]";
  }
  for (const int cpu : o.cpu_workers) {
    if (!cpu_ok(cpu)) return "pipeline.cpu_workers must each be in [-1, 1023]";
  }
  if (o.cpu_workers.size() > static_cast<std::size_t>(o.mapping_workers - 1)) {
    return "pipeline.cpu_workers names more CPUs than there are workers (mapping_workers - 1)";
  }
  return "";
}

bool load_pipeline_options(const std::string& config_path, PipelineOptions* options,
                           std::string* error) {
  YAML::Node root;
  return hal::load_file(config_path, &root, error) &&
         parse_pipeline_section(root, config_path, options, error);
}

bool load_pipeline_options_text(const std::string& text, const std::string& name,
                                PipelineOptions* options, std::string* error) {
  YAML::Node root;
  return hal::load_text(text, name, &root, error) &&
         parse_pipeline_section(root, name, options, error);
}

}  // namespace zonemap::runtime
