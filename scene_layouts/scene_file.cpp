#include "scene_layouts/scene_file.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <set>

#include "mocap_io/input_file.h"
#include "mocap_io/install_layout.h"
#include "mocap_io/json_reader.h"
#include "mocap_io/motion_file.h"

namespace odyssey::scene {
namespace {

namespace fs = std::filesystem;
using io::JsonValue;

// A path as the file gives it: "data:..." in the bundled folder, relative to the file's folder,
// or absolute.
std::string resolve(const JsonValue& value, const fs::path& base) {
  const std::string text = value.string();
  if (text.empty()) value.fail("an empty path");
  if (text.starts_with("data:")) return (fs::path(bundled_data_folder()) / text.substr(5)).lexically_normal().string();
  const fs::path path(text);
  return (path.is_absolute() ? path : base / path).lexically_normal().string();
}

Eigen::Vector3d vector3(const JsonValue& value) {
  if (value.size() != 3) value.fail("expected [x, y, z], got " + std::to_string(value.size()) + " numbers");
  return Eigen::Vector3d(value[0].number(), value[1].number(), value[2].number());
}

std::string name_of(const JsonValue& item, const std::string& fallback) {
  if (const auto name = item.find("name")) {
    const std::string text = name->string();
    if (text.empty() || text.find_first_of("/\\\0", 0, 3) != std::string::npos || text == "." || text == "..") {
      name->fail("a name must be non-empty and hold no slash (it names output files)");
    }
    return text;
  }
  return fallback;
}

// The length of a played source: "loops" or "seconds", not both.
PlaybackLength read_length(const JsonValue& item) {
  PlaybackLength length;
  if (const auto value = item.find("loops")) length.loops = static_cast<int>(value->integer(1, 1'000'000));
  if (const auto value = item.find("seconds")) {
    if (length.loops) value->fail("give loops or seconds, not both");
    length.seconds = value->number_in(0, 1e6);
  }
  return length;
}

// A played source's scale (lengths are multiplied by it).
double read_scale(const JsonValue& item) { return item.find("scale") ? item.member("scale").number_in(1e-9, 1e9) : 1.0; }

// A character's own animation ("character" and "animation").
AnimationRequest read_animation_request(const JsonValue& item, const JsonValue& animation, const fs::path& base) {
  AnimationRequest request;
  request.scale = read_scale(item);
  for (const char* key : {"source_fps", "up"}) {
    if (const auto value = item.find(key)) value->fail("only an anime actor takes this key");
  }
  request.character_path = resolve(item.member("character"), base);
  request.animation = animation.string();
  if (request.animation.empty()) animation.fail("an empty animation name");
  request.length = read_length(item);
  return request;
}

// A DeformingThings4D mesh ("anime", its "source_fps" and "up").
AnimeRequest read_anime_request(const JsonValue& item, const JsonValue& anime, const fs::path& base) {
  AnimeRequest request;
  request.scale = read_scale(item);
  if (const auto character = item.find("character")) character->fail("an anime actor's mesh is its anime file: it takes no character");
  request.path = resolve(anime, base);
  if (const auto value = item.find("source_fps")) request.source_fps = value->number_in(1e-3, 1e4);
  if (const auto value = item.find("up")) {
    const std::string axis = value->string();
    if (axis != "y" && axis != "z") value->fail("expected y or z");
    request.up_z = axis == "z";
  }
  request.length = read_length(item);
  return request;
}

// A motion retargeted onto a character ("motion" and "character", and the retargeting settings).
RetargetRequest read_retarget_request(const JsonValue& item, const fs::path& base) {
  retarget::Quality quality = retarget::Quality::balanced;
  if (const auto value = item.find("quality")) {
    const auto parsed = retarget::parse_quality(value->string());
    if (!parsed) value->fail("expected fast, balanced or accurate");
    quality = *parsed;
  }
  RetargetRequest r = retarget_request(resolve(item.member("motion"), base), resolve(item.member("character"), base), quality);
  if (const auto value = item.find("model")) r.model_path = resolve(*value, base);
  if (const auto value = item.find("betas")) {
    const auto policy = parse_betas_policy(value->string());
    if (!policy) value->fail(std::string("expected ") + kBetasPolicyNames);
    r.betas = *policy;
  }
  if (const auto value = item.find("map")) r.map_path = resolve(*value, base);
  if (const auto value = item.find("source_map")) r.source_map_path = resolve(*value, base);
  if (const auto value = item.find("bvh_units"); value && !(value->is_string() && value->string() == "auto")) {
    r.bvh_metres_per_unit = value->is_number() ? std::optional<double>(value->number()) : io::parse_bvh_units(value->string());
    if (!r.bvh_metres_per_unit || !(*r.bvh_metres_per_unit > 0)) value->fail(std::string("expected ") + io::kBvhUnitsHelp);
  }
  if (const auto value = item.find("parts")) {
    const auto parts = retarget::parse_parts(value->string());
    if (!parts) value->fail("expected body, body+hands or all");
    r.parts = *parts;
  }
  if (const auto value = item.find("weights")) {
    if (!value->is_object()) value->fail("expected an object of weights, e.g. {\"foot_contact\": 50}");
    for (const auto& [name, weight] : value->raw().items()) {
      double* target = retarget::refine_weight(r.refine_options.weights, name);
      const JsonValue entry = value->member(name);
      if (!target) entry.fail("unknown refinement weight");
      *target = entry.number_in(0, 1e12);
    }
  }
  if (const auto value = item.find("contact_lift")) {
    if (value->is_string()) {
      if (value->string() != "off") value->fail("expected metres (>= 0) or \"off\"");
      r.refine_options.contact_lift.reset();
    } else {
      r.refine_options.contact_lift = value->number_in(0, 1e3);
    }
  }
  // Fast runs no refinement: its settings would be taken and silently do nothing.
  for (const char* key : {"weights", "contact_lift"}) {
    if (const auto value = item.find(key); value && quality == retarget::Quality::fast) {
      value->fail("a refinement setting, which quality fast does not run (use balanced or accurate)");
    }
  }
  if (const auto value = item.find("source_rest")) {
    const std::string text = value->string();
    if (text == "rest") {
      r.options.source_rest = retarget::SourceRest::rest;
    } else if (text == "first-frame") {
      r.options.source_rest = retarget::SourceRest::first_frame;
    } else {
      value->fail("expected rest or first-frame");
    }
  }
  return r;
}

// The actor's source, named by its keys: "animation" or "anime" plays one, else "motion" is
// retargeted. Keys of the other sources are refused.
ActorSource read_source(const JsonValue& item, const fs::path& base) {
  const auto animation = item.find("animation"), anime = item.find("anime");
  if (!animation && !anime) {
    for (const char* key : {"loops", "seconds", "scale", "source_fps", "up"}) {
      if (const auto value = item.find(key)) value->fail("only an actor with an animation or an anime takes this key");
    }
    return read_retarget_request(item, base);
  }
  if (animation && anime) anime->fail("an actor plays an animation or an anime, not both");
  if (const auto motion = item.find("motion")) motion->fail("an actor with " + std::string(anime ? "an anime" : "an animation") +
                                                            " plays it: it takes no motion");
  for (const char* key : {"model", "betas", "bvh_units", "quality", "parts", "weights", "contact_lift", "map", "source_map",
                          "source_rest"}) {
    if (const auto value = item.find(key)) value->fail("a retargeting setting, but this actor plays its own motion");
  }
  if (animation) return read_animation_request(item, *animation, base);
  return read_anime_request(item, *anime, base);
}

void read_placement_and_timing(const JsonValue& item, SceneActor& actor) {
  if (const auto value = item.find("placement")) {
    if (value->is_string()) {
      if (value->string() != "as recorded") value->fail("expected \"as recorded\" or an object");
    } else {
      value->allow_only({"x", "y", "yaw", "region"});
      if (const auto region = value->find("region")) {
        if (value->find("x") || value->find("y")) region->fail("give a region or x and y, not both");
        if (region->size() != 4) region->fail("expected [x_min, y_min, x_max, y_max]");
        const Eigen::Vector2d low((*region)[0].number(), (*region)[1].number());
        const Eigen::Vector2d high((*region)[2].number(), (*region)[3].number());
        if (!(high.array() >= low.array()).all()) region->fail("the maximum lies below the minimum");
        actor.placement.kind = Placement::Kind::random;
        actor.placement.region = Eigen::AlignedBox2d(low, high);
        if (value->find("yaw")) value->member("yaw").fail("a random placement draws the yaw too");
      } else {
        actor.placement.kind = Placement::Kind::fixed;
        actor.placement.x = value->member("x").number();
        actor.placement.y = value->member("y").number();
        if (const auto yaw = value->find("yaw")) actor.placement.yaw_deg = yaw->number();
      }
    }
  }
  if (const auto value = item.find("start")) {
    if (value->is_array()) {
      if (value->size() != 2) value->fail("expected a time in seconds or a range [min, max] drawn from the seed");
      actor.start_range = std::pair((*value)[0].number_in(-1e6, 1e6), (*value)[1].number_in(-1e6, 1e6));
      if (actor.start_range->second < actor.start_range->first) (*value)[1].fail("the range's maximum lies below its minimum");
    } else {
      actor.start_s = value->number_in(-1e6, 1e6);
    }
  }
  if (const auto value = item.find("trim")) {
    if (value->size() != 2) value->fail("expected [from, to] in seconds of the clip");
    actor.trim_start_s = (*value)[0].number_in(0, 1e7);
    actor.trim_end_s = (*value)[1].number_in(0, 1e7);
    if (!(*actor.trim_end_s > actor.trim_start_s)) (*value)[1].fail("the trim must end after it starts");
  }
  if (const auto value = item.find("speed")) {
    actor.speed = value->number_in(1e-3, 1e3);
  }
  if (const auto value = item.find("points")) actor.points = static_cast<int>(value->integer(0, 10'000'000));
  if (const auto value = item.find("sampling")) {
    const std::string text = value->string();
    if (text != "surface" && text != "vertices") value->fail("expected surface or vertices");
    actor.sampling = text == "surface" ? skinning::SamplingMode::surface : skinning::SamplingMode::vertices;
  }
}

SceneActor read_actor(const JsonValue& item, std::size_t index, const fs::path& base) {
  item.allow_only({"name", "motion", "character", "model", "betas", "bvh_units", "quality", "parts", "fps", "weights",
                   "contact_lift", "map", "source_map", "source_rest", "placement", "start", "trim", "speed", "points",
                   "sampling", "animation", "anime", "loops", "seconds", "scale", "source_fps", "up"});
  SceneActor actor;
  actor.name = name_of(item, "actor" + std::to_string(index));
  actor.source = read_source(item, base);
  read_placement_and_timing(item, actor);
  return actor;
}

// A dynamic prop's keys (scene.h, Prop::Dynamics); they belong to dynamic props only.
void read_dynamics(const JsonValue& item, const std::string& kind, Prop& prop) {
  const bool dynamic = item.find("dynamic") && item.member("dynamic").boolean();
  if (!dynamic) {
    for (const char* key : {"mass", "friction", "restitution", "velocity", "angular_velocity", "collision"}) {
      if (const auto value = item.find(key)) value->fail("only a dynamic prop (\"dynamic\": true) takes this key");
    }
    return;
  }
  if (kind == "ground") item.member("dynamic").fail("a ground cannot be dynamic");
  Prop::Dynamics& d = prop.dynamics.emplace();
  if (const auto value = item.find("mass")) {
    d.mass = value->number();
    if (!(d.mass > 0) || d.mass > 1e6) value->fail("a mass is kilograms in (0, 1e6], got " + std::to_string(d.mass));
  }
  if (const auto value = item.find("friction")) d.friction = value->number_in(0, 2);
  if (const auto value = item.find("restitution")) d.restitution = value->number_in(0, 1);
  // Speeds beyond these are no prop's: 1 km/s, 1000 rad/s.
  const auto bounded = [](const JsonValue& value, double limit, const char* unit) {
    const Eigen::Vector3d v = vector3(value);
    if (!v.allFinite() || v.norm() > limit) value.fail(std::string("expected a finite [x, y, z] in ") + unit + " of norm at most " + std::to_string(int(limit)));
    return v;
  };
  if (const auto value = item.find("velocity")) d.velocity = bounded(*value, 1e3, "m/s");
  if (const auto value = item.find("angular_velocity")) d.angular_velocity = bounded(*value, 1e3, "rad/s");
  if (const auto value = item.find("collision")) {
    const std::string shape = value->string();
    if (kind != "mesh") value->fail("only a mesh chooses its collision shape (a box collides as a box)");
    if (shape != "hull" && shape != "pieces") value->fail("expected hull or pieces");
    d.pieces = shape == "pieces";
  }
}

// A region [x_min, y_min, x_max, y_max] of the ground.
Eigen::AlignedBox2d read_region(const JsonValue& region) {
  if (region.size() != 4) region.fail("expected [x_min, y_min, x_max, y_max]");
  const Eigen::Vector2d low(region[0].number(), region[1].number()), high(region[2].number(), region[3].number());
  if (!(low.array() < high.array()).all()) region.fail("expected x_min < x_max and y_min < y_max");
  return Eigen::AlignedBox2d(low, high);
}

SceneForces read_forces(const JsonValue& item) {
  item.allow_only({"count", "rate", "speed_change", "max_upward", "lever_arm"});
  SceneForces forces;
  if (const auto value = item.find("count")) forces.count = value->number_in(0, 1e6);
  if (const auto value = item.find("rate")) {
    if (forces.count) value->fail("give count or rate, not both");
    forces.rate = value->number_in(0, 1e3);
  }
  if (const auto value = item.find("speed_change")) {
    if (value->size() != 2) value->fail("expected [min, max] in m/s");
    forces.min_speed_change = (*value)[0].number_in(0, 1e3);
    forces.max_speed_change = (*value)[1].number_in(0, 1e3);
    if (forces.min_speed_change > forces.max_speed_change) value->fail("expected min <= max");
  }
  if (const auto value = item.find("max_upward")) forces.max_upward = value->number_in(0, 1);
  if (const auto value = item.find("lever_arm")) forces.lever_arm = value->number_in(0, 100);
  return forces;
}

Prop read_prop(const JsonValue& item, std::size_t index, const fs::path& base);

SceneScatter read_scatter(const JsonValue& item, const fs::path& base) {
  item.allow_only({"count", "props", "region", "on_paths", "gap"});
  SceneScatter scatter;
  scatter.count = static_cast<int>(item.member("count").integer(1, 100'000));
  const JsonValue props = item.member("props");
  if (props.size() == 0) props.fail("a scatter needs at least one prop to draw from");
  for (std::size_t p = 0; p < props.size(); ++p) {
    scatter.props.push_back(read_prop(props[p], p, base));
    if (!props[p].find("name")) scatter.props.back().name = "scatter" + std::to_string(p);
    if (scatter.props.back().kind == Prop::Kind::ground) props[p].member("type").fail("a ground cannot be scattered");
    for (const char* key : {"position", "yaw"}) {
      if (const auto value = props[p].find(key)) value->fail("a scattered prop's place is drawn: it takes no position or yaw");
    }
  }
  if (const auto value = item.find("region")) scatter.region = read_region(*value);
  if (const auto value = item.find("on_paths")) {
    scatter.on_paths = static_cast<int>(value->integer(0, scatter.count));
  }
  if (const auto value = item.find("gap")) scatter.gap = value->number_in(0, 100);
  return scatter;
}

Prop read_prop(const JsonValue& item, std::size_t index, const fs::path& base) {
  item.allow_only({"name", "type", "size", "path", "up", "position", "yaw", "scale", "category", "dynamic", "mass", "friction",
                   "restitution", "velocity", "angular_velocity", "collision"});
  Prop prop;
  prop.name = name_of(item, "prop" + std::to_string(index));
  const JsonValue type = item.member("type");
  const std::string kind = type.string();
  if (const auto category = item.find("category")) {
    const std::string name = category->string();
    if (kind == "ground") category->fail("a ground's category is ground");
    if (name == "prop") {
      prop.category = PropCategory::prop;
    } else if (name == "structure") {
      prop.category = PropCategory::structure;
    } else {
      category->fail("expected prop or structure");
    }
  }
  if (kind == "ground") prop.category = PropCategory::ground;
  if (kind == "ground") {
    prop.kind = Prop::Kind::ground;
    const JsonValue size = item.member("size");
    if (size.size() != 2) size.fail("a ground's size is [x, y] in metres");
    prop.size = Eigen::Vector3d(size[0].number_in(1e-6, 1e6), size[1].number_in(1e-6, 1e6), 0);
  } else if (kind == "box") {
    prop.kind = Prop::Kind::box;
    const JsonValue size = item.member("size");
    if (size.size() != 3) size.fail("a box's size is [x, y, z] in metres");
    prop.size = Eigen::Vector3d(size[0].number_in(1e-6, 1e6), size[1].number_in(1e-6, 1e6), size[2].number_in(1e-6, 1e6));
  } else if (kind == "mesh") {
    prop.kind = Prop::Kind::mesh;
    prop.path = resolve(item.member("path"), base);
    if (const auto up = item.find("up")) {
      const std::string axis = up->string();
      if (axis != "y" && axis != "z") up->fail("expected y or z");
      prop.up_z = axis == "z";
    }
  } else {
    type.fail("expected ground, box or mesh");
  }
  if (kind != "mesh") {
    if (item.find("path")) item.member("path").fail("only a mesh prop has a path");
    if (item.find("up")) item.member("up").fail("only a mesh prop has an up axis");
  }
  if (kind == "mesh" && item.find("size")) item.member("size").fail("a mesh prop takes scale, not size");
  if (const auto value = item.find("position")) prop.position = vector3(*value);
  if (const auto value = item.find("yaw")) prop.yaw_deg = value->number();
  if (const auto value = item.find("scale")) prop.scale = value->number_in(1e-6, 1e6);
  read_dynamics(item, kind, prop);
  return prop;
}

// What a camera kind's reader may need beside the camera's JSON object.
struct CameraContext {
  const std::vector<SceneActor>& actors;
  const fs::path& base;
};

// The camera kinds' readers. Each reads only its own keys (the caller has checked that the object
// holds no others), in the order the keys are listed in read_camera's allow_only.
CameraRig read_static(const JsonValue& item, const CameraContext&) {
  StaticRig rig;
  if (const auto value = item.find("position")) rig.position = vector3(*value);
  if (const auto value = item.find("target")) rig.target = vector3(*value);
  if (const auto value = item.find("jitter")) rig.jitter_m = value->number_in(0, 1e3);
  return rig;
}

CameraRig read_orbit(const JsonValue& item, const CameraContext&) {
  OrbitRig rig;
  if (const auto value = item.find("target")) rig.target = vector3(*value);
  if (const auto value = item.find("radius")) rig.radius = value->number_in(1e-6, 1e6);
  if (const auto value = item.find("height_m")) rig.height_m = value->number();
  if (const auto value = item.find("period")) {
    rig.period_s = value->number();
    if (rig.period_s == 0) value->fail("a period of 0 seconds");
  }
  if (const auto value = item.find("start_angle")) rig.start_angle_deg = value->number();
  if (const auto value = item.find("jitter")) rig.jitter_m = value->number_in(0, 1e3);
  return rig;
}

CameraRig read_ego(const JsonValue& item, const CameraContext& context) {
  EgoRig rig;
  if (const auto value = item.find("actor")) {
    if (value->is_string()) {
      const std::string name = value->string();
      rig.actor = -1;
      for (std::size_t a = 0; a < context.actors.size(); ++a) {
        if (context.actors[a].name == name) rig.actor = static_cast<int>(a);
      }
      if (rig.actor < 0) value->fail("no actor is called '" + name + "'");
    } else {
      rig.actor = static_cast<int>(value->integer(0, static_cast<long long>(context.actors.size()) - 1));
    }
  }
  // Known here, so said here with the file and JSON path, not when the shot is prepared.
  if (rig.actor >= 0 && static_cast<std::size_t>(rig.actor) < context.actors.size() &&
      !std::holds_alternative<RetargetRequest>(context.actors[rig.actor].source)) {
    const SceneActor& actor = context.actors[rig.actor];
    const bool anime = std::holds_alternative<AnimeRequest>(actor.source);
    (item.find("actor") ? item.member("actor") : item)
        .fail("actor '" + actor.name + "' plays " + (anime ? "an anime mesh" : "its character's own animation") +
              ", which has no bone map: an ego camera rides on the head and hips of a retargeted motion");
  }
  if (const auto value = item.find("eye_forward")) rig.eye_forward = value->number();
  if (const auto value = item.find("eye_up")) rig.eye_up = value->number();
  if (const auto value = item.find("smoothing")) rig.smoothing_s = value->number_in(0, 1e3);
  return rig;
}

CameraRig read_file(const JsonValue& item, const CameraContext& context) {
  return FileRig{resolve(item.member("path"), context.base)};
}

CameraRig read_swoop(const JsonValue& item, const CameraContext&) {
  SwoopRig rig;
  if (const auto value = item.find("target")) rig.target = vector3(*value);
  if (const auto value = item.find("radius")) rig.radius = value->number_in(1e-6, 1e6);
  if (const auto value = item.find("height_m")) rig.height_m = value->number();
  if (const auto value = item.find("start_angle")) rig.start_angle_deg = value->number();
  if (const auto value = item.find("height_end")) rig.height_end_m = value->number();
  if (const auto value = item.find("sweep")) rig.sweep_deg = value->number_in(-1e5, 1e5);
  return rig;
}

CameraRig read_dolly_zoom(const JsonValue& item, const CameraContext&) {
  DollyZoomRig rig;
  if (const auto value = item.find("position")) rig.position = vector3(*value);
  if (const auto value = item.find("target")) rig.target = vector3(*value);
  if (const auto value = item.find("end_distance")) rig.end_distance = value->number_in(1e-6, 1e6);
  return rig;
}

CameraRig read_zoom(const JsonValue& item, const CameraContext&) {
  ZoomRig rig;
  if (const auto value = item.find("position")) rig.position = vector3(*value);
  if (const auto value = item.find("target")) rig.target = vector3(*value);
  if (const auto value = item.find("hfov_end")) {
    rig.hfov_end_deg = value->number();
    if (!(*rig.hfov_end_deg > 0 && *rig.hfov_end_deg < 180)) value->fail("expected degrees between 0 and 180");
  }
  return rig;
}

ImportedRig read_imported(const JsonValue& item, const CameraContext& context, ImportedRig::Format format) {
  ImportedRig rig;
  rig.format = format;
  if (const auto value = item.find("target")) rig.target = vector3(*value);
  if (const auto value = item.find("height_m")) rig.height_m = value->number();
  if (const auto value = item.find("start_angle")) rig.start_angle_deg = value->number();
  rig.path = resolve(item.member("path"), context.base);
  if (const auto value = item.find("extent")) rig.extent_m = value->number_in(1e-6, 1e6);
  if (const auto value = item.find("anchor")) {
    const std::string anchor = value->string();
    if (anchor != "centroid" && anchor != "focus") value->fail("expected centroid or focus");
    rig.anchor_focus = anchor == "focus";
  }
  if (const auto value = item.find("speed")) rig.speed = value->number_in(1e-3, 1e3);
  if (const auto value = item.find("fps")) rig.source_fps = value->number_in(1e-3, 1e4);
  if (const auto value = item.find("up")) {
    rig.up = vector3(*value);
    if (!(rig.up->norm() > 0)) value->fail("the up direction must not be zero");
  }
  if (const auto value = item.find("aim")) rig.aim_smoothing_s = value->number_in(0, 1e3);
  return rig;
}

CameraRig read_realestate10k(const JsonValue& item, const CameraContext& context) {
  return read_imported(item, context, ImportedRig::Format::realestate10k);
}

CameraRig read_colmap(const JsonValue& item, const CameraContext& context) {
  return read_imported(item, context, ImportedRig::Format::colmap);
}

// A camera kind of the file: its "type", the keys it takes beside name, type and handheld, and its
// reader. Imported tracks carry their own intrinsics (only the output image size is the scene's);
// a camera path file carries all of its camera.
struct CameraKind {
  const char* type;
  std::set<std::string> keys;
  CameraRig (*read)(const JsonValue& item, const CameraContext& context);
};

const std::vector<CameraKind>& camera_kinds() {
  static const std::vector<CameraKind> kinds{
      {"static", {"width", "height", "hfov", "position", "target", "jitter"}, read_static},
      {"orbit", {"width", "height", "hfov", "target", "radius", "height_m", "period", "start_angle", "jitter"}, read_orbit},
      {"ego", {"width", "height", "hfov", "actor", "eye_forward", "eye_up", "smoothing"}, read_ego},
      {"file", {"path"}, read_file},
      {"swoop", {"width", "height", "hfov", "target", "radius", "height_m", "height_end", "start_angle", "sweep"}, read_swoop},
      {"dolly-zoom", {"width", "height", "hfov", "position", "target", "end_distance"}, read_dolly_zoom},
      {"zoom", {"width", "height", "hfov", "position", "target", "hfov_end"}, read_zoom},
      {"realestate10k",
       {"width", "height", "path", "extent", "anchor", "target", "height_m", "start_angle", "speed", "up", "aim"},
       read_realestate10k},
      {"colmap",
       {"width", "height", "path", "extent", "anchor", "target", "height_m", "start_angle", "speed", "up", "aim", "fps"},
       read_colmap},
  };
  return kinds;
}

SceneCamera read_camera(const JsonValue& item, std::size_t index, const std::vector<SceneActor>& actors,
                        const fs::path& base) {
  item.allow_only({"name", "type", "width", "height", "hfov", "position", "target", "radius", "height_m", "period",
                   "start_angle", "actor", "eye_forward", "eye_up", "smoothing", "path", "jitter", "height_end", "sweep",
                   "end_distance", "hfov_end", "extent", "anchor", "speed", "fps", "up", "aim", "handheld"});
  SceneCamera camera;
  camera.name = name_of(item, "camera" + std::to_string(index));
  const JsonValue type = item.member("type");
  const std::string type_name = type.string();
  const auto kind = std::find_if(camera_kinds().begin(), camera_kinds().end(),
                                 [&](const CameraKind& k) { return type_name == k.type; });
  if (kind == camera_kinds().end()) type.fail("expected static, orbit, ego, file, swoop, dolly-zoom, zoom, realestate10k or colmap");
  for (const auto& [key, value] : item.raw().items()) {
    const bool shared = key == "name" || key == "type" || key == "handheld";
    if (!shared && !kind->keys.contains(key)) item.member(key).fail("not a key of a " + type_name + " camera");
  }
  if (const auto value = item.find("width")) camera.width = static_cast<int>(value->integer(1, 1 << 16));
  if (const auto value = item.find("height")) camera.height = static_cast<int>(value->integer(1, 1 << 16));
  if (const std::string problem = io::image_size_problem(camera.width, camera.height); !problem.empty()) {
    item.member(item.find("width") ? "width" : "height").fail(problem);
  }
  if (const auto value = item.find("hfov")) {
    camera.hfov_deg = value->number();
    if (!(camera.hfov_deg > 0 && camera.hfov_deg < 180)) value->fail("expected degrees between 0 and 180");
  }
  camera.rig = kind->read(item, CameraContext{actors, base});
  if (const auto value = item.find("handheld")) {
    value->allow_only({"amplitude", "rotation", "band"});
    HandheldOptions handheld;
    if (const auto amplitude = value->find("amplitude")) handheld.amplitude_m = amplitude->number_in(0, 1e3);
    if (const auto rotation = value->find("rotation")) handheld.rotation_deg = rotation->number_in(0, 45);
    if (const auto band = value->find("band")) {
      if (band->size() != 2) band->fail("expected [low, high] in Hz");
      handheld.low_hz = (*band)[0].number_in(1e-6, 1e6);
      handheld.high_hz = (*band)[1].number_in(1e-6, 1e6);
      if (handheld.high_hz < handheld.low_hz) (*band)[1].fail("the band's high end lies below its low end");
    }
    camera.handheld = handheld;
  }
  return camera;
}

}  // namespace

std::string bundled_data_folder() {
  if (const char* folder = std::getenv("ODYSSEY_DATA_DIR"); folder && *folder) return folder;
  static const std::string installed_or_source = io::runtime_folder("data", ODYSSEY_DATA_DIR);
  return installed_or_source;
}

SceneFile parse_scene(const std::string& json_text, const std::string& path) {
  const io::JsonDocument document = io::JsonDocument::parse(json_text, path);
  const JsonValue root = document.root();
  root.allow_only({"version", "name", "fps", "seconds", "seed", "actors", "props", "forces", "scatter", "cameras", "outputs", "description"});
  const long long version = root.member("version").integer(1, 1000);
  if (version != kSceneFileVersion) {
    root.member("version").fail("version " + std::to_string(version) + " is not one this odyssey reads (it reads " +
                                std::to_string(kSceneFileVersion) + ")");
  }
  const fs::path base = fs::absolute(path).parent_path();
  SceneFile file;
  Scene& scene = file.scene;
  scene.name = name_of(root, fs::path(path).stem().string());
  if (const auto value = root.find("description")) value->string();
  if (const auto value = root.find("fps")) scene.fps = value->number_in(1e-3, 1e4);
  if (const auto value = root.find("seconds")) scene.seconds = value->number_in(0, 1e6);
  if (const auto value = root.find("seed")) scene.seed = static_cast<std::uint64_t>(value->integer(0, 1LL << 53));
  const JsonValue actors = root.member("actors");
  if (actors.size() == 0) actors.fail("a scene needs at least one actor");
  std::set<std::string> names;
  for (std::size_t a = 0; a < actors.size(); ++a) {
    scene.actors.push_back(read_actor(actors[a], a, base));
    std::visit([&](auto& request) { request.fps = scene.fps; }, scene.actors.back().source);
    if (actors[a].find("fps")) actors[a].member("fps").fail("actors run at the scene's fps");
    if (!names.insert(scene.actors.back().name).second) actors[a].member("name").fail("two actors have this name");
  }
  if (const auto props = root.find("props")) {
    for (std::size_t p = 0; p < props->size(); ++p) {
      scene.props.push_back(read_prop((*props)[p], p, base));
      if (!names.insert(scene.props.back().name).second) (*props)[p].member("name").fail("an actor or prop has this name");
    }
  }
  if (const auto scatter = root.find("scatter")) {
    scene.scatter = read_scatter(*scatter, base);
    for (std::size_t p = 0; p < scene.scatter->props.size(); ++p) {
      if (!names.insert(scene.scatter->props[p].name).second) (*scatter).member("props")[p].member("name").fail("an actor or prop has this name");
    }
  }
  if (const auto forces = root.find("forces")) {
    scene.forces = read_forces(*forces);
    const auto dynamic = [](const Prop& prop) { return prop.dynamics.has_value(); };
    if (std::none_of(scene.props.begin(), scene.props.end(), dynamic) &&
        !(scene.scatter && std::any_of(scene.scatter->props.begin(), scene.scatter->props.end(), dynamic))) {
      forces->fail("no dynamic prop for the forces to act on");
    }
  }
  if (const auto cameras = root.find("cameras")) {
    std::set<std::string> camera_names;
    for (std::size_t c = 0; c < cameras->size(); ++c) {
      scene.cameras.push_back(read_camera((*cameras)[c], c, scene.actors, base));
      if (!camera_names.insert(scene.cameras.back().name).second) (*cameras)[c].member("name").fail("two cameras have this name");
    }
  }
  if (const auto outputs = root.find("outputs")) {
    outputs->allow_only({"trajectories", "camera_paths", "point_caches", "actor_reports", "report", "previews", "glb", "points_per_actor",
                         "prop_points", "body_points_only", "compress", "threads", "layout", "depth", "normals", "masks",
                         "exact_maps"});
    OutputSelection& which = file.outputs;
    if (const auto value = outputs->find("trajectories")) which.trajectories = value->boolean();
    if (const auto value = outputs->find("camera_paths")) which.camera_paths = value->boolean();
    if (const auto value = outputs->find("point_caches")) which.point_caches = value->boolean();
    if (const auto value = outputs->find("actor_reports")) which.actor_reports = value->boolean();
    if (const auto value = outputs->find("report")) which.report = value->boolean();
    if (const auto value = outputs->find("previews")) which.previews = value->boolean();
    if (const auto value = outputs->find("glb")) which.glb = value->boolean();
    if (which.previews && scene.cameras.empty()) outputs->member("previews").fail("previews need a camera");
    SceneOutputs& out = scene.outputs;
    if (const auto value = outputs->find("points_per_actor")) out.points_per_actor = static_cast<int>(value->integer(0, 10'000'000));
    if (const auto value = outputs->find("prop_points")) out.prop_points = static_cast<int>(value->integer(0, 10'000'000));
    if (const auto value = outputs->find("body_points_only")) out.body_points_only = value->boolean();
    if (const auto value = outputs->find("compress")) out.compress = value->boolean();
    if (const auto value = outputs->find("threads")) out.threads = static_cast<int>(value->integer(1, 1024));
    if (const auto value = outputs->find("layout")) {
      const std::string layout = value->string();
      if (layout == "files") {
        which.layout = OutputSelection::Layout::files;
      } else if (layout == "pointodyssey") {
        which.layout = OutputSelection::Layout::pointodyssey;
      } else {
        value->fail("expected files or pointodyssey");
      }
    }
    if (const auto value = outputs->find("depth")) out.dense.depth = value->boolean();
    if (const auto value = outputs->find("normals")) out.dense.normals = value->boolean();
    if (const auto value = outputs->find("masks")) out.dense.masks = value->boolean();
    if (const auto value = outputs->find("exact_maps")) out.dense.exact = value->boolean();
    if (out.prop_points > 0 && scene.props.empty() && !scene.scatter) outputs->member("prop_points").fail("the scene has no props");
    if (which.trajectories && scene.cameras.empty()) outputs->member("trajectories").fail("trajectories need a camera");
  }
  // Trajectories are written by default, for every camera there is.
  if (scene.cameras.empty() && !(root.find("outputs") && root.member("outputs").find("trajectories"))) {
    file.outputs.trajectories = false;
  }
  if (file.outputs.trajectories) {
    long total = scene.outputs.prop_points;
    for (const SceneActor& actor : scene.actors) total += actor.points.value_or(scene.outputs.points_per_actor);
    if (total == 0) root.member("outputs").fail("trajectories asked for, but zero points to track");
  }
  return file;
}

SceneFile read_scene_file(const std::string& path) {
  SceneFile file = parse_scene(io::read_text_file(path), path);
  file.scene.file = path;
  return file;
}

std::string example_scene_json() { return io::read_text_file((fs::path(bundled_data_folder()) / "scenes" / "indoor.json").string()); }

void set_outputs_in_folder(Scene& scene, const std::string& folder, const OutputSelection& which) {
  const fs::path dir(folder);
  SceneOutputs& out = scene.outputs;
  out.trajectories.clear();
  out.camera_paths.clear();
  out.previews.clear();
  out.point_caches.clear();
  out.actor_reports.clear();
  out.sequences.clear();
  const bool sequences = which.layout == OutputSelection::Layout::pointodyssey;
  for (const SceneCamera& camera : scene.cameras) {
    if (which.trajectories && sequences) out.sequences.push_back((dir / (scene.name + "_" + camera.name)).string());
    if (which.trajectories && !sequences) out.trajectories.push_back((dir / ("trajectories_" + camera.name + ".npz")).string());
    if (which.camera_paths) out.camera_paths.push_back((dir / ("camera_" + camera.name + ".json")).string());
    if (which.previews) out.previews.push_back((dir / ("preview_" + camera.name + ".png")).string());
  }
  for (const SceneActor& actor : scene.actors) {
    if (which.point_caches) out.point_caches.push_back((dir / ("point_cache_" + actor.name + ".pc2")).string());
    if (which.actor_reports) out.actor_reports.push_back((dir / ("retarget_" + actor.name + ".json")).string());
  }
  const bool props = !scene.props.empty() || (scene.scatter && scene.scatter->count > 0);
  out.prop_point_cache = which.point_caches && props ? (dir / "props_point_cache.pc2").string() : std::string();
  out.report = which.report ? (dir / "report.json").string() : std::string();
  out.scene_glb = which.glb ? (dir / "scene.glb").string() : std::string();
}

}  // namespace odyssey::scene
