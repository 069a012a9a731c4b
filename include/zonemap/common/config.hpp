// Mapping configuration (loaded by hal/, validated here so every front end
// applies the same limits).
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include "zonemap/common/time_watermark.hpp"

namespace zonemap {

// Build-time maxima: the runtime configuration must stay within them. The zone
// pool reserves 8 zones of the configured size, so the largest zone is what
// bounds memory (the paper's flight-2 zone, 160x160x80, is 2,048,000 cells).
inline constexpr std::size_t kMaxZoneCells = 4'194'304;  // e.g. 256x256x64
inline constexpr int kMaxZoneEdgeCells = 1024;
inline constexpr int kMaxImageWidth = 2048;
inline constexpr int kMaxImageHeight = 2048;
inline constexpr int kMaxDepthFilterRadius = 8;  // sensor.depth_filter_radius (pixels)
inline constexpr int kZonesHeld = 8;             // a zone-sized cube overlaps at most 2x2x2 zones

struct SkyFilterConfig {
  bool enabled = true;
  int min_intensity = 200;  // left-image brightness that may be sky (0..255)
  int max_gradient = 8;     // largest 3x3 neighbour difference of a low-texture region
  // Sky only well above the horizon the pose gives, never continuing well below it
  // (attitude error, camera mount): SkyFilter, docs/sky.md.
  double horizon_margin_deg = 2.0;
  // A bright flat run with a measured pixel at most this many rows under it rests
  // on that surface (stereo leaves edges unmatched for a few pixels): not sky.
  int max_gap_px = 4;
  // A bright flat region smaller than this share of the image (a pane of a white
  // facade) is not sky.
  double min_region_share = 0.01;
};

// The feature map (paper §IV) and the ground model (past the paper).
struct FeatureConfig {
  double occupied_threshold_units = 1.5;  // fused value above which a cell belongs to an object
  int min_cells = 3;                      // smaller objects are noise (counted)
  int capacity = 4096;                    // features held in the store
  int quadtree_groups = 65536;            // footprint quadtree nodes, in groups of four
  int extract_every_frames = 10;          // each zone holding a grid re-extracted about this often,
                                          // one zone per frame at most (bounded work per frame)
  double reintegration_units = 4.0;       // value written into a re-allocated zone's object cells
  int merge_gap_cells = 1;  // per-zone features this close across zones are one object
  // Objects that touch are split where the fused value dips between them
  // (FeatureMap::split_at_valleys): cores are connected parts of at least
  // core_min_cells cells near the object's peak value; every cell goes to its
  // nearest core. false: never split (the paper's).
  bool split_touching = true;
  int core_min_cells = 8;
  // Only cells holding at least peak_fraction of the largest fused value within
  // peak_window_m in x and y (and a cell in z) belong to objects (PeakTrim in
  // zone_snapshot.hpp): the halo that far views and the blur leave around a
  // surface stays out of the boxes. 0: every occupied cell (the paper's).
  double peak_fraction = 0.0;
  double peak_window_m = 1.5;
  // Ground: a column's terrain height is the lowest occupied cell, taken as the
  // minimum over a window, where at least min_coverage of the window's observed
  // columns (any cell known free or occupied) have an occupied cell: a surface, not
  // a thing standing in free space. Occupied cells up to thickness_m above it are
  // ground.
  bool ground_enabled = true;
  double ground_thickness_m = 2.0;  // long-range stereo smears the ground upwards (eq. 5)
  double ground_window_m = 6.0;
  double ground_min_coverage = 0.5;
  // Where far views made the ground band thicker than thickness_m (grazing rays, a
  // slope facing the camera), the band as measured: per column, the occupied run
  // rising from the lowest cell; the band_percentile of those run heights over the
  // window (objects' columns rise higher and fall above it), at most
  // max_thickness_m. band_percentile 0: thickness_m alone.
  double ground_band_percentile = 0.0;
  double ground_max_thickness_m = 4.0;
};
inline constexpr int kMaxGroundBandCells = 32;
inline constexpr int kMaxPeakWindowCells = 16;  // bounds the band's per-height tables

struct MapConfig {
  double cell_size_m = 1.0;
  std::array<int, 3> zone_cells = {80, 80, 10};  // zone = sensor environment size
  // Where the sensor environment (a zone-sized cube) sits about the camera. The
  // paper centres it; a camera looking down then never maps what stands below
  // half the environment's height ("objects 5 m below the helicopter are not
  // recorded"). kBelow puts the camera above_camera_m under the environment's top,
  // so the rest of its height reaches down towards the ground.
  enum class Placement { kCentred, kBelow };
  Placement placement = Placement::kCentred;  // shipped configs name theirs
  double above_camera_m = 2.0;
  double d_min_m = 8.0;
  double d_max_m = 50.0;
  int pixel_step = 1;  // 1 maps every pixel, as the paper does
  // Past the paper: each depth averaged with the depths of its surface around it
  // (DepthFilter, 2r + 1 taps along the row, then the column) before the sensor
  // model. 0: every depth as measured (the paper's).
  int depth_filter_radius_px = 0;
  // How a frame is drawn into the local grid: walking every pixel's ray (the
  // reference) or visiting every frustum cell once (projective, fast).
  enum class Integration { kReference, kProjective };
  Integration integration = Integration::kProjective;  // the reference stays available by name
  // Past the paper (max-write keeps a ray's uncertainty band wherever it reaches):
  // a cell that some ray crossed wholly in its free part, and in which no ray came
  // within (1 - see_through) Δd of its measured depth (m̂ >= see_through), is free
  // in that frame: the rays that passed through show the band there is the
  // measurement's spread, not a thing. What stands in a cell is kept by the rays
  // that end in it. 0: off (the paper's max-write).
  double see_through = 0.0;
  // A cell behind a ray's measured depth (the ray ended before it) is kept by
  // that ray when its m̂ there reaches see_through_behind (at most see_through;
  // < 0: see_through). Lower than see_through, it keeps what lies just behind a
  // measured surface (the inside of a trunk whose edge rays pass) while the band
  // in front of a surface is still seen through.
  double see_through_behind = -1.0;
  double near_peak_behind() const {
    return see_through_behind < 0.0 ? see_through : see_through_behind;
  }
  int blur_radius = 1;  // binomial kernel radius (0 = no blur)
  // Past the paper: a cell whose centre lies within this depth along the optical
  // axis keeps at least half the occupancy it had before the blur (0 = off). The
  // blur spreads a surface over eq. (1)'s uncertainty; near the camera Δd is far
  // under a cell, and a thin post there, one cell between cells seen free, kept
  // 1/8 of its value (LocalGrid::finish). At most kMaxKeepNearCells cells.
  double blur_keep_near_m = 0.0;
  static constexpr int kMaxKeepNearCells = 16;
  // Eq. (7) adds every view alike (kEqual, the paper's); kRangeWeighted scales a
  // view's occupied evidence by (δ_full / δ)², at least min_weight, beyond δ_full,
  // the depth at which eq. (1)'s Δd is full_weight_resolution_cells cells
  // (LocalGrid::weight_occupancy_by_range): near views sharpen what far views blurred.
  enum class Fusion { kEqual, kRangeWeighted };
  Fusion fusion = Fusion::kEqual;  // the paper's; configs name range where measured better
  double full_weight_resolution_cells = 1.0;
  double min_weight = 0.5;
  double saturation_units = 64.0;         // |fused cell| limit, in sensor-model units
  double occupied_threshold_units = 1.5;  // fused value above which a cell is occupied
  double free_threshold_units = -1.0;     // fused value below which a cell is free
  SkyFilterConfig sky;
  double pose_max_gap_s = 0.1;        // largest gap between two poses interpolated over
  double pose_tolerance_s = 0.02;     // nearest pose accepted at the ends of a trajectory
  double depth_scale_override = 0.0;  // > 0 replaces camera.yaml's depth_scale (TUM: 5000)
  // Time order of frames and poses (time_watermark.hpp): a lone stamp far off costs
  // only its item; a step that persists over confirm_values stamps is adopted.
  TimeWatermarkConfig timestamps;
  FeatureConfig features;
  // The file's `pipeline:` section (timing, real-time set-up) is the runtime's:
  // runtime/runtime_config reads it into runtime::PipelineOptions.
};

// Returns an empty string when the configuration is usable, else what is wrong.
std::string validate(const MapConfig& config);

inline std::size_t zone_cell_count(const MapConfig& config) {
  return static_cast<std::size_t>(config.zone_cells[0]) *
         static_cast<std::size_t>(config.zone_cells[1]) *
         static_cast<std::size_t>(config.zone_cells[2]);
}

}  // namespace zonemap
