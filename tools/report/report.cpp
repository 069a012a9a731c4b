#include "tools/report/report.hpp"

#include <algorithm>

#include <cstdio>
#include <cstring>
#include <fstream>

#include "hal/record/foxglove_json.hpp"

namespace zonemap::tools {

extern const char kReportViewerBundle[];  // report_assets.cpp (generated)
extern const char kReportTablesScript[];

namespace {

constexpr const char* kNoViewMarker = "/* zonemap: no 3-D view */";

// The run's data for both scripts, as one JSON document. A script element's text
// must not contain "</": JSON escapes it as "<\/".
std::string data_json(const ReportInputs& in) {
  std::string out;
  record::JsonWriter j(&out);
  j.begin_object();
  j.key("title").string(in.title);
  j.key("world_z_up").boolean(in.world_z_up);
  j.key("cell_size_m").number(in.cell_size_m);
  j.key("stats").json(in.stats_json.empty() ? "{}" : in.stats_json);
  j.key("evaluation").json(in.evaluation_json.empty() ? "null" : in.evaluation_json);
  j.key("boxes").begin_array();
  for (std::size_t i = 0; i < in.boxes.size(); ++i) {
    const ObstacleBox& b = in.boxes[i];
    j.begin_object();
    j.key("id").integer(b.id);
    j.key("kind").string(b.kind == FeatureKind::kGround ? "ground" : "obstacle");
    j.key("prior").boolean(b.prior);
    j.key("min").begin_array().number(b.min.x()).number(b.min.y()).number(b.min.z()).end_array();
    j.key("max").begin_array().number(b.max.x()).number(b.max.y()).number(b.max.z()).end_array();
    j.key("rects").begin_array();
    if (i < in.footprints.size()) {
      for (const FootprintRect& r : in.footprints[i]) {
        j.begin_array().number(r.x0).number(r.y0).number(r.x1).number(r.y1).end_array();
      }
    }
    j.end_array().end_object();
  }
  j.end_array();
  j.key("trajectory").begin_array();
  for (const Eigen::Vector3d& p : in.trajectory) j.number(p.x()).number(p.y()).number(p.z());
  j.end_array();
  j.key("occupied").begin_array();
  for (float v : in.occupied) j.number(v);
  j.end_array();
  j.key("frame_ms").begin_array();
  for (double ms : in.frame_ms) j.number(ms);
  j.end_array();
  j.key("end_to_end_bins").begin_array();
  for (const auto& [edge, count] : in.end_to_end_bins) {
    j.begin_array().number(edge).integer(static_cast<std::int64_t>(count)).end_array();
  }
  j.end_array();
  j.end_object();
  std::string safe;
  safe.reserve(out.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (out[i] == '<' && i + 1 < out.size() && out[i + 1] == '/') {
      safe += "<\\/";
      ++i;
    } else {
      safe += out[i];
    }
  }
  return safe;
}

// A script's text as a <script> element may hold it: "</script" would end it.
std::string script_text(const char* code) {
  std::string out(code);
  for (std::size_t at = 0; (at = out.find("</script", at)) != std::string::npos; at += 2) {
    out.replace(at, 2, "<\\/");
  }
  return out;
}

std::string base64(const std::string& bytes) {
  std::string out;
  record::JsonWriter(&out).base64(bytes.data(), bytes.size());
  return out.substr(1, out.size() - 2);  // without the quotes
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') {
      out += "&lt;";
    } else if (c == '>') {
      out += "&gt;";
    } else if (c == '&') {
      out += "&amp;";
    } else {
      out += c;
    }
  }
  return out;
}

// Errors of any script on the page (and console.error) land in the body's
// data-errors attribute and a visible line, so a headless check can read them.
constexpr const char* kErrorCatcher = R"(<script>
(function () {
  var errors = [];
  function note(message) {
    errors.push(String(message));
    document.documentElement.setAttribute("data-errors", errors.join(" | "));
    var line = document.getElementById("errors");
    if (line) line.textContent = "Errors on this page: " + errors.join(" | ");
  }
  window.addEventListener("error", function (e) { note(e.message || e); });
  window.addEventListener("unhandledrejection", function (e) { note(e.reason); });
  var original = console.error;
  console.error = function () {
    note(Array.prototype.join.call(arguments, " "));
    original.apply(console, arguments);
  };
})();
</script>
)";

constexpr const char* kStyle = R"(<style>
body { font: 14px/1.4 system-ui, sans-serif; margin: 0 1.5em 2em; color: #222; }
h1 { font-size: 20px; } h2 { font-size: 16px; margin-top: 1.5em; }
#view { width: 100%; height: 560px; background: #15181c; }
.row { display: flex; flex-wrap: wrap; gap: 2em; align-items: flex-start; }
table { border-collapse: collapse; font-size: 12px; }
td, th { border: 1px solid #ccc; padding: 2px 6px; text-align: left; }
#errors { color: #b00; font-weight: bold; }
img.height { max-width: 100%; image-rendering: pixelated; border: 1px solid #ccc; }
</style>
)";

}  // namespace

bool report_has_3d_view() {
  return std::strncmp(kReportViewerBundle, kNoViewMarker, std::strlen(kNoViewMarker)) != 0;
}

bool write_report(const std::string& path, const ReportInputs& in, std::string* error) {
  std::ofstream out(path, std::ios::binary);
  if (!out) {
    *error = path + ": cannot create";
    return false;
  }
  out << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>zonemap: "
      << html_escape(in.title) << "</title>\n"
      << kErrorCatcher << kStyle << "</head><body>\n"
      << "<h1>zonemap run: " << html_escape(in.title) << "</h1>\n<p id=\"errors\"></p>\n"
      << "<p>" << in.boxes.size()
      << " boxes (boxes.csv), drawn with their quadtree footprints (obstacles orange, ground "
         "brown, a prior map's boxes no view has confirmed violet: "
      << std::count_if(in.boxes.begin(), in.boxes.end(),
                       [](const ObstacleBox& b) { return b.prior; })
      << "); the occupied cells of the zones holding a grid at the end"
      << (in.occupied.size() / 3 >= kReportOccupiedCells ? " (a regular sample)" : "")
      << "; the flight in blue. Drag to orbit, wheel to zoom, right-drag to pan.</p>\n";
  if (report_has_3d_view()) {
    out << "<div id=\"view\"></div>\n";
  } else {
    out << "<p>No 3-D view in this build: npm was not reachable when it was built "
           "(tools/report).</p>\n";
  }
  out << "<div class=\"row\"><div><h2>Height profile (height.png)</h2>\n";
  if (!in.height_png.empty()) {
    out << "<img class=\"height\" alt=\"height profile\" src=\"data:image/png;base64,"
        << base64(in.height_png) << "\">\n";
  }
  out << "</div><div><h2>Timing</h2>\n"
      << "<canvas id=\"frame-times\" width=\"520\" height=\"200\"></canvas><br>\n"
      << "<canvas id=\"latency\" width=\"520\" height=\"200\"></canvas></div></div>\n"
      << "<h2>Evaluation against objects.yaml</h2><div id=\"evaluation\"></div>\n"
      << "<h2>Every counter of stats.json</h2><div id=\"stats\"></div>\n"
      << "<script id=\"zonemap-data\" type=\"application/json\">" << data_json(in)
      << "</script>\n<script>" << script_text(kReportTablesScript) << "</script>\n";
  if (report_has_3d_view()) out << "<script>" << script_text(kReportViewerBundle) << "</script>\n";
  out << "</body></html>\n";
  out.close();
  if (!out) {
    *error = path + ": write failed";
    return false;
  }
  return true;
}

}  // namespace zonemap::tools
