#include "hal/record/foxglove_json.hpp"

#include <cmath>
#include <cstdio>

namespace zonemap::record {

void JsonWriter::separate() {
  if (need_comma_) out_->push_back(',');
  need_comma_ = false;
}

JsonWriter& JsonWriter::key(std::string_view name) {
  separate();
  out_->push_back('"');
  out_->append(name);
  out_->append("\":");
  need_comma_ = false;
  return *this;
}

JsonWriter& JsonWriter::json(std::string_view value) {
  separate();
  out_->append(value);
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::number(double v) {
  separate();
  char buf[32];
  const int n = std::snprintf(buf, sizeof(buf), "%.9g", std::isfinite(v) ? v : 0.0);
  out_->append(buf, static_cast<std::size_t>(n));
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::integer(std::int64_t v) {
  separate();
  out_->append(std::to_string(v));
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::string(std::string_view s) {
  separate();
  out_->push_back('"');
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out_->push_back('\\');
      out_->push_back(c);
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\u%04x", static_cast<unsigned>(c));
      out_->append(buf);
    } else {
      out_->push_back(c);
    }
  }
  out_->push_back('"');
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::boolean(bool v) {
  separate();
  out_->append(v ? "true" : "false");
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::begin_object() {
  separate();
  out_->push_back('{');
  return *this;
}

JsonWriter& JsonWriter::end_object() {
  out_->push_back('}');
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::begin_array() {
  separate();
  out_->push_back('[');
  return *this;
}

JsonWriter& JsonWriter::end_array() {
  out_->push_back(']');
  need_comma_ = true;
  return *this;
}

std::uint64_t time_ns(double seconds) {
  if (!std::isfinite(seconds) || seconds <= 0.0) return 0;
  return static_cast<std::uint64_t>(std::llround(seconds * 1e9));
}

JsonWriter& JsonWriter::time(double seconds) {
  const std::uint64_t ns = time_ns(seconds);
  begin_object();
  key("sec").integer(static_cast<std::int64_t>(ns / 1000000000u));
  key("nsec").integer(static_cast<std::int64_t>(ns % 1000000000u));
  return end_object();
}

JsonWriter& JsonWriter::vector3(const Eigen::Vector3d& v) {
  begin_object();
  key("x").number(v.x());
  key("y").number(v.y());
  key("z").number(v.z());
  return end_object();
}

JsonWriter& JsonWriter::quaternion(const Eigen::Quaterniond& q) {
  begin_object();
  key("x").number(q.x());
  key("y").number(q.y());
  key("z").number(q.z());
  key("w").number(q.w());
  return end_object();
}

JsonWriter& JsonWriter::pose(const Eigen::Vector3d& position,
                             const Eigen::Quaterniond& orientation) {
  begin_object();
  key("position").vector3(position);
  key("orientation").quaternion(orientation);
  return end_object();
}

JsonWriter& JsonWriter::color(float r, float g, float b, float a) {
  begin_object();
  key("r").number(r);
  key("g").number(g);
  key("b").number(b);
  key("a").number(a);
  return end_object();
}

// RFC 4648 base64 with padding.
JsonWriter& JsonWriter::base64(const void* data, std::size_t size) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  separate();
  const auto* p = static_cast<const std::uint8_t*>(data);
  out_->push_back('"');
  out_->reserve(out_->size() + (size + 2) / 3 * 4 + 2);
  std::size_t i = 0;
  for (; i + 3 <= size; i += 3) {
    const std::uint32_t v = (p[i] << 16) | (p[i + 1] << 8) | p[i + 2];
    out_->push_back(kAlphabet[(v >> 18) & 63]);
    out_->push_back(kAlphabet[(v >> 12) & 63]);
    out_->push_back(kAlphabet[(v >> 6) & 63]);
    out_->push_back(kAlphabet[v & 63]);
  }
  if (i < size) {
    const std::uint32_t v = (p[i] << 16) | (i + 1 < size ? p[i + 1] << 8 : 0);
    out_->push_back(kAlphabet[(v >> 18) & 63]);
    out_->push_back(kAlphabet[(v >> 12) & 63]);
    out_->push_back(i + 1 < size ? kAlphabet[(v >> 6) & 63] : '=');
    out_->push_back('=');
  }
  out_->push_back('"');
  need_comma_ = true;
  return *this;
}

// --- Schemas -------------------------------------------------------------------
// Shared definitions, spliced into each schema.
#define ZONEMAP_JSON_DEFS                                                                     \
  R"("$defs":{)"                                                                              \
  R"("time":{"type":"object","properties":{"sec":{"type":"integer","minimum":0},)"            \
  R"("nsec":{"type":"integer","minimum":0,"maximum":999999999}},"required":["sec","nsec"]},)" \
  R"("vector3":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},)"  \
  R"("z":{"type":"number"}},"required":["x","y","z"]},)"                                      \
  R"("quaternion":{"type":"object","properties":{"x":{"type":"number"},)"                     \
  R"("y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}},)"                    \
  R"("required":["x","y","z","w"]},)"                                                         \
  R"("pose":{"type":"object","properties":{"position":{"$ref":"#/$defs/vector3"},)"           \
  R"("orientation":{"$ref":"#/$defs/quaternion"}},"required":["position","orientation"]},)"   \
  R"("color":{"type":"object","properties":{"r":{"type":"number"},"g":{"type":"number"},)"    \
  R"("b":{"type":"number"},"a":{"type":"number"}},"required":["r","g","b","a"]})"             \
  R"(})"

SchemaText scene_update_schema() {
  return {"foxglove.SceneUpdate",
          R"({"title":"foxglove.SceneUpdate","type":"object",)" ZONEMAP_JSON_DEFS R"(,)"
          R"("properties":{)"
          R"("deletions":{"type":"array","items":{"type":"object","properties":{)"
          R"("timestamp":{"$ref":"#/$defs/time"},"type":{"enum":[0,1]},"id":{"type":"string"}},)"
          R"("required":["timestamp","type","id"]}},)"
          R"("entities":{"type":"array","items":{"type":"object","properties":{)"
          R"("timestamp":{"$ref":"#/$defs/time"},"frame_id":{"type":"string"},)"
          R"("id":{"type":"string"},)"
          R"("lifetime":{"type":"object","properties":{"sec":{"type":"integer"},)"
          R"("nsec":{"type":"integer","minimum":0}},"required":["sec","nsec"]},)"
          R"("frame_locked":{"type":"boolean"},)"
          R"("metadata":{"type":"array","items":{"type":"object","properties":{)"
          R"("key":{"type":"string"},"value":{"type":"string"}},"required":["key","value"]}},)"
          R"("cubes":{"type":"array","items":{"type":"object","properties":{)"
          R"("pose":{"$ref":"#/$defs/pose"},"size":{"$ref":"#/$defs/vector3"},)"
          R"("color":{"$ref":"#/$defs/color"}},"required":["pose","size","color"]}},)"
          R"("lines":{"type":"array","items":{"type":"object","properties":{)"
          R"("type":{"enum":[0,1,2]},"pose":{"$ref":"#/$defs/pose"},)"
          R"("thickness":{"type":"number"},"scale_invariant":{"type":"boolean"},)"
          R"("points":{"type":"array","items":{"$ref":"#/$defs/vector3"}},)"
          R"("color":{"$ref":"#/$defs/color"},)"
          R"("colors":{"type":"array","items":{"$ref":"#/$defs/color"}},)"
          R"("indices":{"type":"array","items":{"type":"integer","minimum":0}}},)"
          R"("required":["type","pose","thickness","scale_invariant","points","color","colors",)"
          R"("indices"]}},)"
          R"("triangles":{"type":"array","items":{"type":"object","properties":{)"
          R"("pose":{"$ref":"#/$defs/pose"},)"
          R"("points":{"type":"array","items":{"$ref":"#/$defs/vector3"}},)"
          R"("color":{"$ref":"#/$defs/color"},)"
          R"("colors":{"type":"array","items":{"$ref":"#/$defs/color"}},)"
          R"("indices":{"type":"array","items":{"type":"integer","minimum":0}}},)"
          R"("required":["pose","points","color","colors","indices"]}},)"
          R"("arrows":{"type":"array"},"spheres":{"type":"array"},"cylinders":{"type":"array"},)"
          R"("texts":{"type":"array"},"models":{"type":"array"}},)"
          R"("required":["timestamp","frame_id","id","lifetime","frame_locked","metadata",)"
          R"("arrows","cubes","spheres","cylinders","lines","triangles","texts","models"]}}},)"
          R"("required":["deletions","entities"]})"};
}

SchemaText frame_transform_schema() {
  return {"foxglove.FrameTransform",
          R"({"title":"foxglove.FrameTransform","type":"object",)" ZONEMAP_JSON_DEFS R"(,)"
          R"("properties":{"timestamp":{"$ref":"#/$defs/time"},)"
          R"("parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},)"
          R"("translation":{"$ref":"#/$defs/vector3"},"rotation":{"$ref":"#/$defs/quaternion"}},)"
          R"("required":["timestamp","parent_frame_id","child_frame_id","translation",)"
          R"("rotation"]})"};
}

SchemaText point_cloud_schema() {
  return {"foxglove.PointCloud",
          R"({"title":"foxglove.PointCloud","type":"object",)" ZONEMAP_JSON_DEFS R"(,)"
          R"("properties":{"timestamp":{"$ref":"#/$defs/time"},"frame_id":{"type":"string"},)"
          R"("pose":{"$ref":"#/$defs/pose"},"point_stride":{"type":"integer","minimum":0},)"
          R"("fields":{"type":"array","items":{"type":"object","properties":{)"
          R"("name":{"type":"string"},"offset":{"type":"integer","minimum":0},)"
          R"("type":{"enum":[0,1,2,3,4,5,6,7,8]}},"required":["name","offset","type"]}},)"
          R"("data":{"type":"string","contentEncoding":"base64"}},)"
          R"("required":["timestamp","frame_id","pose","point_stride","fields","data"]})"};
}

SchemaText raw_image_schema() {
  return {"foxglove.RawImage",
          R"({"title":"foxglove.RawImage","type":"object",)" ZONEMAP_JSON_DEFS R"(,)"
          R"("properties":{"timestamp":{"$ref":"#/$defs/time"},"frame_id":{"type":"string"},)"
          R"("width":{"type":"integer","minimum":0},"height":{"type":"integer","minimum":0},)"
          R"("encoding":{"type":"string"},"step":{"type":"integer","minimum":0},)"
          R"("data":{"type":"string","contentEncoding":"base64"}},)"
          R"("required":["timestamp","frame_id","width","height","encoding","step","data"]})"};
}

SchemaText health_schema() {
  return {"zonemap.Health",
          R"({"title":"zonemap.Health","description":"The mapper's counters and latencies, )"
          R"(as stats.json names them","type":"object",)" ZONEMAP_JSON_DEFS R"(,)"
          R"("properties":{"timestamp":{"$ref":"#/$defs/time"},)"
          R"("counters":{"type":"object","additionalProperties":{"type":"integer"}},)"
          R"("latencies_ms":{"type":"object","additionalProperties":{"type":"number"}}},)"
          R"("required":["timestamp","counters","latencies_ms"]})"};
}

#undef ZONEMAP_JSON_DEFS

}  // namespace zonemap::record
