// The recorder's messages as Foxglove's JSON message encoding reads them
// (schemas named as `@foxglove/schemas` names them: foxglove.SceneUpdate, ...):
// times as {sec, nsec}, bytes as base64, enums as integers. And the JSON Schema
// we store with each channel, written for the fields we send.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include <Eigen/Geometry>

namespace zonemap::record {

// Appends JSON text. Commas are its business: every value and key is preceded by
// one when it follows another at the same level.
class JsonWriter {
 public:
  explicit JsonWriter(std::string* out) : out_(out) {}
  JsonWriter& raw(std::string_view text) {
    out_->append(text);
    return *this;
  }
  JsonWriter& key(std::string_view name);    // "name": (a comma first when needed)
  JsonWriter& json(std::string_view value);  // a value that is already JSON text
  JsonWriter& number(double v);              // finite; non-finite written as 0
  JsonWriter& integer(std::int64_t v);
  JsonWriter& string(std::string_view s);  // quoted, escaped
  JsonWriter& boolean(bool v);
  JsonWriter& begin_object();
  JsonWriter& end_object();
  JsonWriter& begin_array();
  JsonWriter& end_array();
  JsonWriter& time(double seconds);  // {"sec":..,"nsec":..}, clamped at 0
  JsonWriter& vector3(const Eigen::Vector3d& v);
  JsonWriter& quaternion(const Eigen::Quaterniond& q);
  JsonWriter& pose(const Eigen::Vector3d& position, const Eigen::Quaterniond& orientation);
  JsonWriter& color(float r, float g, float b, float a);
  JsonWriter& base64(const void* data, std::size_t size);

 private:
  void separate();
  std::string* out_;
  bool need_comma_ = false;
};

// Nanoseconds of a sensor time in seconds (0 for negative or non-finite times).
std::uint64_t time_ns(double seconds);

// Our JSON Schemas, by the schema name each is stored under.
struct SchemaText {
  const char* name;
  const char* json;
};
SchemaText scene_update_schema();
SchemaText frame_transform_schema();
SchemaText point_cloud_schema();
SchemaText raw_image_schema();
SchemaText health_schema();  // zonemap.Health: the run's counters by name

}  // namespace zonemap::record
