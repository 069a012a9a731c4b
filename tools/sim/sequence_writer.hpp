// A generated flight written to disk in the replay layout; rendering itself
// (scene.hpp) writes nothing.
#pragma once

#include <string>
#include <vector>

#include "tools/sim/scene.hpp"

namespace zonemap::sim {

// Writes a whole sequence directory (camera.yaml, depth.txt, depth/, left.txt,
// left/, groundtruth.txt, objects.yaml). Each frame shows the scene at its time;
// objects.yaml gives a moving object where it is at the last frame.
bool write_sequence(const std::string& dir, const Scene& scene, const CameraModel& camera,
                    const std::vector<TimedPose>& trajectory, const RenderOptions& options,
                    std::string* error);

// sightings: from render() over the flight (pixel_hits, seen_top_z).
bool write_objects_yaml(const std::string& path, const Scene& scene,
                        const ObjectSightings& sightings, std::string* error);

}  // namespace zonemap::sim
