#include "tools/sim/scenarios.hpp"

#include <cmath>

#include "tools/sim/scene.hpp"

namespace zonemap::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// Straight flight from a to b at constant speed, nose along the track.
std::vector<TimedPose> straight(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double speed,
                                double pitch_down, double rate) {
  const double length = (b - a).norm();
  const int frames = std::max(2, static_cast<int>(std::floor(length / speed * rate)) + 1);
  const double yaw = std::atan2(b.y() - a.y(), b.x() - a.x());
  std::vector<TimedPose> out;
  for (int i = 0; i < frames; ++i) {
    const double f = static_cast<double>(i) / (frames - 1);
    out.push_back({i / rate, look_pose(a + f * (b - a), yaw, pitch_down)});
  }
  return out;
}

// An 800 m route flown out and back at 10-20 m altitude over huts and trees
// standing 8-30 m either side of the track every 40-60 m: every zone is left
// behind and comes back, every object is seen from both sides.
void route_scene(std::uint64_t seed, double rate, Scenario* s) {
  s->description = "an 800 m route out and back over huts and trees";
  s->config = "config/outdoor-0.5m.yaml";
  Rng rng(seed * 7919 + 11);
  const double altitude = 10.0 + 10.0 * rng.uniform();
  int huts = 0, trees = 0;
  for (double x = 60.0; x < 780.0; x += 40.0 + 20.0 * rng.uniform()) {
    const double side = rng.uniform() < 0.5 ? -1.0 : 1.0;
    const double y = side * (8.0 + 22.0 * rng.uniform());
    if (rng.uniform() < 0.5) {
      const double w = 3.0 + 2.0 * rng.uniform(), h = 3.0 + 1.5 * rng.uniform();
      s->scene.boxes.push_back({"hut_" + std::to_string(++huts), Eigen::Vector3d(x, y - w / 2, 0.0),
                                Eigen::Vector3d(x + w, y + w / 2, h)});
    } else {
      s->scene.cylinders.push_back({"tree_" + std::to_string(++trees), Eigen::Vector2d(x, y),
                                    1.0 + rng.uniform(), 0.0, 6.0 + 5.0 * rng.uniform()});
    }
  }
  s->trajectory = straight({0, 0, altitude}, {800, 0, altitude}, 8.0, 15 * kDeg, rate);
  const double t_turn = s->trajectory.back().time_s + 1.0 / rate;
  for (TimedPose p : straight({800, 0, altitude}, {0, 0, altitude}, 8.0, 15 * kDeg, rate)) {
    p.time_s += t_turn;
    s->trajectory.push_back(p);
  }
}

// A hover 3 m up turning once on the spot, with two posts, a wall and a low box
// 3-7 m away (seen nowhere farther) and a tree 20 m out: what a helicopter near
// the ground must see though it never flew toward it.
void hover_near_scene(std::uint64_t seed, double rate, Scenario* s) {
  s->description = "a hover turning on the spot 3 m up, posts, a wall and a box 3-7 m away";
  s->config = "config/outdoor-0.5m.yaml";
  Rng rng(seed * 104729 + 3);
  const auto at = [&](double bearing_deg, double range) {
    return Eigen::Vector2d(range * std::cos(bearing_deg * kDeg),
                           range * std::sin(bearing_deg * kDeg));
  };
  s->scene.cylinders.push_back(
      {"post_a", at(20.0 * rng.uniform(), 3.5 + 2.0 * rng.uniform()), 0.15, 0.0, 5.0});
  s->scene.cylinders.push_back(
      {"post_b", at(100.0 + 20.0 * rng.uniform(), 4.5 + 2.5 * rng.uniform()), 0.2, 0.0, 6.0});
  const double wall_y = -(4.0 + 2.5 * rng.uniform());
  s->scene.boxes.push_back(
      {"wall", Eigen::Vector3d(-2.5, wall_y - 0.3, 0.0), Eigen::Vector3d(1.5, wall_y, 3.0)});
  const Eigen::Vector2d crate = at(200.0 + 20.0 * rng.uniform(), 4.0 + 2.0 * rng.uniform());
  s->scene.boxes.push_back({"crate", Eigen::Vector3d(crate.x() - 0.6, crate.y() - 0.6, 0.0),
                            Eigen::Vector3d(crate.x() + 0.6, crate.y() + 0.6, 1.2)});
  s->scene.cylinders.push_back({"tree", at(45.0, 20.0), 1.5, 0.0, 9.0});
  const int frames = static_cast<int>(12.0 * rate);  // one turn in 12 s
  for (int i = 0; i < frames; ++i) {
    const double yaw = 2.0 * kPi * i / frames;
    s->trajectory.push_back({i / rate, look_pose(Eigen::Vector3d(0.0, 0.0, 3.0), yaw, 15 * kDeg)});
  }
}

// Terrain rising (or falling) 8-14% from x = 30 m on, with two poles, a hut and a
// wall standing on it, each set into the slope where it stands.
void terrain_scene(bool rises, std::uint64_t seed, Scenario* s) {
  Rng rng(seed);
  s->description = rises ? "terrain rising ahead with two poles, a hut and a wall on it, at 20 m"
                         : "terrain falling ahead with two poles, a hut and a wall on it, at 20 m";
  s->config = "config/paper-flight2.yaml";
  s->scene.slope = (rises ? 1.0 : -1.0) * (0.08 + 0.06 * rng.uniform());
  s->scene.slope_start_x = 30.0;
  const Scene& ground = s->scene;
  const double poles_x = 48.0 + 4.0 * rng.uniform();
  for (const double y : {-4.0, 4.0}) {
    const double base = ground.ground_height(poles_x);
    s->scene.cylinders.push_back(
        {y < 0 ? "pole_a" : "pole_b", Eigen::Vector2d(poles_x, y), 0.3, base, base + 6.0});
  }
  const double hut_x = 56.0 + 4.0 * rng.uniform();
  const double hut_base = std::min(ground.ground_height(hut_x), ground.ground_height(hut_x + 4.0));
  s->scene.boxes.push_back({"hut", Eigen::Vector3d(hut_x, 6.0, hut_base),
                            Eigen::Vector3d(hut_x + 4.0, 10.0, hut_base + 3.5)});
  const double wall_x = 64.0 + 4.0 * rng.uniform();
  const double wall_base = ground.ground_height(wall_x);
  s->scene.boxes.push_back({"wall", Eigen::Vector3d(wall_x, -14.0, wall_base - 0.1),
                            Eigen::Vector3d(wall_x + 0.5, -4.0, wall_base + 2.5)});
}

// White, textureless things stereo cannot match (SkyFilter must not take them for
// sky), under open sky: a house wall flown at and passed beside at 6 m, a tall
// building filling the view above the horizon, a white van seen from above.
void white_scene(const std::string& name, double rate, Scenario* s) {
  s->config = "config/paper-flight2.yaml";
  Box wall{"white_wall", Eigen::Vector3d(60.0, -10.0, 0.0), Eigen::Vector3d(60.5, 10.0, 9.0)};
  wall.white = true;
  if (name == "white-wall") {
    s->description = "a white house wall 9 m tall flown at, from 45 m to 15 m, at 6 m";
    s->scene.boxes.push_back(wall);
    s->trajectory = straight({15, 0, 6.0}, {45, 0, 6.0}, 3.0, 5 * kDeg, rate);
  } else if (name == "white-wall-beside") {
    s->description = "a white house wall 9 m tall passed beside at 10 m, at 6 m";
    wall.min = Eigen::Vector3d(30.0, 10.0, 0.0);
    wall.max = Eigen::Vector3d(70.0, 10.5, 9.0);
    s->scene.boxes.push_back(wall);
    s->trajectory = straight({0, 0, 6.0}, {80, 0, 6.0}, 4.0, 5 * kDeg, rate);
  } else if (name == "white-tower") {
    s->description =
        "a white building 30 m tall rising above the horizon, flown at from 60 m to 25 m";
    wall.name = "white_tower";
    wall.min = Eigen::Vector3d(60.0, -15.0, 0.0);
    wall.max = Eigen::Vector3d(75.0, 15.0, 30.0);
    s->scene.boxes.push_back(wall);
    s->trajectory = straight({0, 0, 8.0}, {35, 0, 8.0}, 3.0, 0.0, rate);
  } else {  // white-van
    s->description = "a white van on a field, a post beside it, flown over at 8 m";
    Box van{"white_van", Eigen::Vector3d(40.0, -1.0, 0.0), Eigen::Vector3d(45.0, 1.0, 2.2)};
    van.white = true;
    s->scene.boxes.push_back(van);
    s->scene.cylinders.push_back({"post", Eigen::Vector2d(42.0, 5.0), 0.25, 0.0, 5.0});
    s->trajectory = straight({0, 0, 8.0}, {38, 0, 8.0}, 3.0, 12 * kDeg, rate);
  }
}

}  // namespace

CameraModel paper_camera(int width) {
  CameraModel c;
  c.width = width;
  c.height = width * 3 / 4;
  c.fx = 669.0 * width / 640.0;
  c.fy = c.fx;
  c.cx = (c.width - 1) / 2.0;
  c.cy = (c.height - 1) / 2.0;
  c.baseline_m = 0.30;
  c.match_sigma_px = 0.25;
  c.depth_scale = 1000.0;
  return c;
}

std::vector<std::string> scenario_names() {
  return {"bushes",          "treeline",     "posts-through",  "posts-around",
          "posts-staggered", "out-and-back", "treeline-dense", "hedge",
          "hedge-beside",    "posts-high",   "crossing-car",   "parked-car",
          "terrain-rise",    "terrain-fall", "white-wall",     "white-wall-beside",
          "white-tower",     "white-van",    "field-grazing",  "route-out-and-back",
          "sitl-course",     "hover-near"};
}

bool make_scenario(const std::string& name, const ScenarioOptions& options, Scenario* s,
                   std::string* error) {
  if (options.width < 16 || options.width > 2048 || !(options.frame_rate_hz > 0.0)) {
    *error = "width must be in [16, 2048] and the frame rate > 0";
    return false;
  }
  s->name = name;
  s->camera = paper_camera(options.width);
  s->scene = Scene{};
  const double rate = options.frame_rate_hz;
  if (name == "bushes") {
    s->description = "flight 1: a line of bushes between fields and a small aircraft, low flight";
    s->config = "config/paper-flight1.yaml";
    for (int i = 0; i < 12; ++i) {
      const double x = 30.0 + 5.0 * i;
      s->scene.boxes.push_back({"bush_" + std::to_string(i + 1), Eigen::Vector3d(x, 14.0, 0.0),
                                Eigen::Vector3d(x + 3.0, 17.0, 2.5)});
    }
    s->scene.boxes.push_back({"aircraft_fuselage", Eigen::Vector3d(66.0, -13.0, 0.0),
                              Eigen::Vector3d(74.0, -11.0, 2.0)});
    s->scene.boxes.push_back(
        {"aircraft_wing", Eigen::Vector3d(68.5, -18.0, 1.2), Eigen::Vector3d(70.5, -6.0, 1.6)});
    s->trajectory = straight({0, 0, 4.0}, {110, 0, 4.0}, 5.0, 12 * kDeg, rate);
  } else if (name == "treeline") {
    s->description = "flight 2: a line of trees crossed at altitude";
    s->config = "config/paper-flight2.yaml";
    for (int i = 0; i < 6; ++i) {
      const double y = -17.5 + 7.0 * i;
      const double height = 8.0 + 2.0 * (i % 4);  // some higher trees
      s->scene.cylinders.push_back(
          {"tree_" + std::to_string(i + 1), Eigen::Vector2d(60.0, y), 2.0, 0.0, height});
    }
    s->trajectory = straight({0, 0, 18.0}, {100, 0, 18.0}, 5.0, 20 * kDeg, rate);
  } else if (name == "posts-through" || name == "posts-around") {
    s->config = "config/paper-flight3.yaml";
    s->scene.cylinders.push_back({"post_a", Eigen::Vector2d(40.0, -3.5), 0.25, 0.0, 5.0});
    s->scene.cylinders.push_back({"post_b", Eigen::Vector2d(40.0, 3.5), 0.25, 0.0, 5.0});
    if (name == "posts-through") {
      s->description = "flight 3a: two posts 7 m apart, flown through";
      s->trajectory = straight({0, 0, 3.0}, {55, 0, 3.0}, 4.0, 10 * kDeg, rate);
    } else {
      s->description = "flight 3b: a pirouette around two posts, nose to the centre";
      const Eigen::Vector2d centre(40.0, 0.0);
      const double radius = 20.0;
      const double speed = 4.0;
      const int frames = static_cast<int>(2.0 * kPi * radius / speed * rate);
      for (int i = 0; i < frames; ++i) {
        const double a = 2.0 * kPi * i / frames + kPi;  // start west of the posts
        const Eigen::Vector3d p(centre.x() + radius * std::cos(a),
                                centre.y() + radius * std::sin(a), 4.0);
        const double yaw = std::atan2(centre.y() - p.y(), centre.x() - p.x());
        s->trajectory.push_back({i / rate, look_pose(p, yaw, 10 * kDeg)});
      }
    }
  } else if (name == "posts-staggered") {
    // No mirror symmetry: a link that swapped left and right, or a sector off by
    // one, puts a post where none stands.
    s->description = "three posts staggered either side of the track, flown in, a hover";
    s->config = "config/paper-flight2.yaml";
    s->scene.cylinders.push_back({"post_right_near", Eigen::Vector2d(30.0, -2.5), 0.25, 0.0, 8.0});
    s->scene.cylinders.push_back({"post_left", Eigen::Vector2d(40.0, 6.0), 0.25, 0.0, 8.0});
    s->scene.cylinders.push_back({"post_right_far", Eigen::Vector2d(50.0, -9.0), 0.25, 0.0, 8.0});
    // In, then a 10 s hover among the posts (one behind right, one ahead left, one
    // ahead right: a steady scene in three sectors).
    s->trajectory = straight({0, 0, 3.0}, {35, 0, 3.0}, 4.0, 10 * kDeg, rate);
    const TimedPose hover = s->trajectory.back();
    for (int i = 1; i <= static_cast<int>(10.0 * rate); ++i) {
      s->trajectory.push_back({hover.time_s + i / rate, hover.world_T_camera});
    }
  } else if (name == "treeline-dense") {
    // A tree line as users fly it: 18 trees 5.2 m apart with 0.5-3 m gaps, 9-17 m
    // tall, approached from 70 m at 15-25 m altitude (first seen at 40-50 m, where
    // eq. 1's range resolution is 2-3 m).
    s->description = "a dense tree line approached from 70 m at altitude";
    s->config = "config/paper-flight2.yaml";
    Rng rng(options.seed);
    for (int i = 0; i < 18; ++i) {
      const double gap = 0.5 + 2.5 * rng.uniform();
      const double radius = (5.2 - gap) / 2.0;
      const double height = 9.0 + 8.0 * rng.uniform();
      s->scene.cylinders.push_back({"tree_" + std::to_string(i + 1),
                                    Eigen::Vector2d(70.0, -44.2 + 5.2 * i), radius, 0.0, height});
    }
    const double altitude = 15.0 + 10.0 * rng.uniform();
    s->trajectory = straight({0, 0, altitude}, {62, 0, altitude}, 5.0, 20 * kDeg, rate);
  } else if (name == "field-grazing") {
    // Flat open ground seen at grazing angles, as a helicopter flies over fields:
    // 3-25 m altitude, the camera looking at the ground 35-60 m ahead (5-35 deg down
    // there, Δd of eq. 1 1.5-4.5 m), a barn and four trees 42-65 m ahead (passed at
    // 20-45 m). Every box on the ground between them is a false obstacle.
    s->description = "a flat field seen at grazing angles, a barn and trees on it, at 3-25 m";
    s->config = "config/paper-flight2.yaml";
    Rng rng(options.seed);
    const double altitude = 3.0 + 22.0 * rng.uniform();
    const double look_at = 35.0 + 25.0 * rng.uniform();
    const double barn_x = 45.0 + 8.0 * rng.uniform(), barn_y = -20.0 + 10.0 * rng.uniform();
    s->scene.boxes.push_back({"barn", Eigen::Vector3d(barn_x, barn_y, 0.0),
                              Eigen::Vector3d(barn_x + 12.0, barn_y + 8.0, 6.0)});
    for (int i = 0; i < 4; ++i) {
      const double x = 42.0 + 16.0 * rng.uniform(), y = 5.0 + 7.0 * i + 2.0 * rng.uniform();
      s->scene.cylinders.push_back({"tree_" + std::to_string(i + 1), Eigen::Vector2d(x, y),
                                    1.0 + rng.uniform(), 0.0, 6.0 + 6.0 * rng.uniform()});
    }
    s->trajectory =
        straight({0, 0, altitude}, {20, 0, altitude}, 4.0, std::atan2(altitude, look_at), rate);
  } else if (name == "hedge" || name == "hedge-beside") {
    // Bushes 2-3 m tall with 1.4 m gaps and a small aircraft at 10 m. hedge: the row
    // stands across the track and is flown towards, so its gaps are seen along;
    // hedge-beside: the row runs beside the track 14 m off it, where no view of the
    // paper's camera (25.5 deg half field of view) ever looks through a gap.
    const bool beside = name == "hedge-beside";
    s->description = beside ? "a hedge of bushes with gaps beside the track, flown past at 10 m"
                            : "a hedge of bushes with gaps across the track, flown towards at 10 m";
    s->config = "config/paper-flight2.yaml";
    Rng rng(options.seed);
    double along = beside ? 30.0 : -25.0;
    for (int i = 0; i < 14; ++i) {
      const double width = 1.5 + 1.5 * rng.uniform();
      const double height = 2.0 + rng.uniform();
      const Eigen::Vector3d lo =
          beside ? Eigen::Vector3d(along, 14.0, 0.0) : Eigen::Vector3d(60.0, along, 0.0);
      const Eigen::Vector3d hi = beside ? Eigen::Vector3d(along + width, 16.5, height)
                                        : Eigen::Vector3d(62.5, along + width, height);
      s->scene.boxes.push_back({"bush_" + std::to_string(i + 1), lo, hi});
      along += width + 1.4;
    }
    s->scene.boxes.push_back({"aircraft_fuselage",
                              Eigen::Vector3d(beside ? 56.0 : 40.0, -13.0, 0.0),
                              Eigen::Vector3d(beside ? 64.0 : 48.0, -11.0, 2.0)});
    s->trajectory = straight({0, 0, 10.0}, {beside ? 70.0 : 52.0, 0, 10.0}, 5.0, 15 * kDeg, rate);
  } else if (name == "posts-high") {
    // The paper's posts flown through at 8 m: a centred environment of 10 m never
    // reaches the lower 3 m of them.
    s->description = "two posts 7 m apart flown through at 8 m altitude";
    s->config = "config/paper-flight3.yaml";
    s->scene.cylinders.push_back({"post_a", Eigen::Vector2d(40.0, -3.5), 0.25, 0.0, 5.0});
    s->scene.cylinders.push_back({"post_b", Eigen::Vector2d(40.0, 3.5), 0.25, 0.0, 5.0});
    s->trajectory = straight({0, 0, 8.0}, {38, 0, 8.0}, 4.0, 15 * kDeg, rate);
  } else if (name == "crossing-car" || name == "parked-car") {
    // A car (1.5 m tall) stands in the field ahead for the first 3 s of a flight
    // towards a post and a shed at 8 m, then drives away across it: where it stood
    // is seen free again. parked-car: the same car never leaves.
    const bool parked = name == "parked-car";
    s->description =
        parked
            ? "a parked car, a post and a shed, flown towards at 8 m"
            : "a car driving off across the field ahead, a post and a shed, flown towards at 8 m";
    s->config = "config/paper-flight3.yaml";
    Rng rng(options.seed);
    const double post_y = -4.0 + 2.0 * rng.uniform();
    s->scene.cylinders.push_back({"post", Eigen::Vector2d(46.0, post_y), 0.25, 0.0, 5.0});
    s->scene.boxes.push_back(
        {"shed", Eigen::Vector3d(46.0, 5.0, 0.0), Eigen::Vector3d(50.0, 9.0, 3.0)});
    const double speed = parked ? 0.0 : 2.5 + 1.5 * rng.uniform();
    const double direction = rng.uniform() < 0.5 ? 1.0 : -1.0;
    const double lane_x = 36.0 + 3.0 * rng.uniform();
    Box car{"car", Eigen::Vector3d(lane_x, -2.25, 0.0), Eigen::Vector3d(lane_x + 1.8, 2.25, 1.5)};
    car.velocity_mps = Eigen::Vector3d(0.0, direction * speed, 0.0);
    car.departs_s = 3.0;
    s->scene.boxes.push_back(car);
    s->trajectory = straight({0, 0, 8.0}, {24, 0, 8.0}, 3.0, 15 * kDeg, rate);
  } else if (name == "out-and-back") {
    s->description = "a 200 m route flown out and back: zones are discarded and allocated again";
    s->config = "config/paper-flight3.yaml";
    s->scene.cylinders.push_back({"post_a", Eigen::Vector2d(40.0, -3.5), 0.25, 0.0, 5.0});
    s->scene.cylinders.push_back({"post_b", Eigen::Vector2d(40.0, 3.5), 0.25, 0.0, 5.0});
    s->scene.boxes.push_back(
        {"hut_1", Eigen::Vector3d(110.0, 6.0, 0.0), Eigen::Vector3d(114.0, 10.0, 3.0)});
    s->scene.boxes.push_back(
        {"hut_2", Eigen::Vector3d(170.0, -10.0, 0.0), Eigen::Vector3d(173.0, -6.0, 3.0)});
    s->trajectory = straight({0, 0, 3.0}, {200, 0, 3.0}, 8.0, 10 * kDeg, rate);
    const double t_turn = s->trajectory.back().time_s + 1.0 / rate;
    for (TimedPose p : straight({200, 0, 3.0}, {0, 0, 3.0}, 8.0, 10 * kDeg, rate)) {
      p.time_s += t_turn;
      s->trajectory.push_back(p);
    }
  } else if (name == "sitl-course") {
    // The closed-loop course (tools/sitl-flight): from the autopilot's home 60 m
    // north at 10 m altitude, two posts 20 m out (one 1.5 m west of the track, one
    // 4 m east) and a wall across the track 40 m out, all taller than the flight.
    // x north, y west, z up: the autopilot's NED turned about north.
    s->description = "the closed-loop course: two posts and a wall between A and B";
    s->config = "config/outdoor-0.5m.yaml";
    s->scene.cylinders.push_back({"post_west", Eigen::Vector2d(20.0, 1.5), 0.3, 0.0, 16.0});
    s->scene.cylinders.push_back({"post_east", Eigen::Vector2d(20.0, -4.0), 0.3, 0.0, 16.0});
    s->scene.boxes.push_back(
        {"wall", Eigen::Vector3d(40.0, -6.0, 0.0), Eigen::Vector3d(41.0, 6.0, 20.0)});
    s->trajectory = straight({0, 0, 10.0}, {60, 0, 10.0}, 3.0, 10 * kDeg, rate);
  } else if (name == "route-out-and-back") {
    route_scene(options.seed, rate, s);
  } else if (name == "hover-near") {
    hover_near_scene(options.seed, rate, s);
  } else if (name.rfind("white-", 0) == 0 && (name == "white-wall" || name == "white-wall-beside" ||
                                              name == "white-tower" || name == "white-van")) {
    white_scene(name, rate, s);
  } else if (name == "terrain-rise" || name == "terrain-fall") {
    terrain_scene(name == "terrain-rise", options.seed, s);
    s->trajectory = straight({0, 0, 18.0}, {58, 0, 18.0}, 5.0, 20 * kDeg, rate);
  } else {
    std::string names;
    for (const std::string& known : scenario_names()) names += (names.empty() ? "" : ", ") + known;
    *error = "unknown scenario '" + name + "' (" + names + ")";
    return false;
  }
  return true;
}

}  // namespace zonemap::sim
