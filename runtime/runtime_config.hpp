// The `pipeline:` section of a mapping configuration (config/*.yaml): the
// runtime's deadline, pose wait, publish rate and real-time set-up (memory lock,
// SCHED_FIFO priority and CPU per thread). Read here, into PipelineOptions, so that
// the core's MapConfig holds no OS setting; the mapping loader skips the section.
// Strict like it: an unknown key, a wrong type or a value out of range is an error
// naming the file and line. No section: the defaults.
#pragma once

#include <string>

#include "runtime/pipeline.hpp"

namespace zonemap::runtime {

bool load_pipeline_options(const std::string& config_path, PipelineOptions* options,
                           std::string* error);
// The same from text (`name` stands for the file in messages): tests, fuzzing.
bool load_pipeline_options_text(const std::string& text, const std::string& name,
                                PipelineOptions* options, std::string* error);
// Empty when the section's values are usable, else what is wrong.
std::string validate_pipeline_section(const PipelineOptions& options);

}  // namespace zonemap::runtime
