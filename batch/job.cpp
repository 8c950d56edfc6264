#include "batch/job.h"

#include <glob.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>

#include "mocap_io/csv_file.h"
#include "mocap_io/input_error.h"
#include "mocap_io/json_reader.h"
#include "mocap_io/motion_file.h"
#include "retarget/parts.h"
#include "retarget/refine.h"

namespace odyssey::batch {
namespace fs = std::filesystem;
namespace {

constexpr std::pair<const char*, bool JobOutputs::*> kOutputFlags[] = {
    {"glb", &JobOutputs::glb},
    {"report", &JobOutputs::report},
    {"trajectories", &JobOutputs::trajectories},
    {"point-cache", &JobOutputs::point_cache},
    {"preview", &JobOutputs::preview},
};

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

bool has_extension(const fs::path& path, const std::vector<std::string>& extensions) {
  const std::string extension = lower(path.extension().string());
  return std::find(extensions.begin(), extensions.end(), extension) != extensions.end();
}

// "a/b/c.bvh" relative to "a" -> "b/c".
std::string name_below(const fs::path& file, const fs::path& root) {
  fs::path relative = file.lexically_relative(root);
  if (relative.empty() || *relative.begin() == "..") relative = file.filename();
  return (relative.parent_path() / relative.stem()).generic_string();
}

bool is_glob(const std::string& path) { return path.find_first_of("*?[") != std::string::npos; }

std::vector<FoundFile> files_in_folder(const fs::path& folder, const std::vector<std::string>& extensions) {
  std::vector<FoundFile> found;
  std::error_code error;
  fs::recursive_directory_iterator it(folder, fs::directory_options::skip_permission_denied, error), end;
  if (error) throw io::InputError(folder.string(), "cannot read the folder: " + error.message());
  for (; it != end; it.increment(error)) {
    if (error) throw io::InputError(folder.string(), "cannot read the folder: " + error.message());
    if (it->is_regular_file() && has_extension(it->path(), extensions)) {
      found.push_back({it->path().string(), name_below(it->path(), folder)});
    }
  }
  return found;
}

std::vector<FoundFile> files_matching(const std::string& pattern, const std::vector<std::string>& extensions) {
  // The glob's fixed leading folder: the components before the first with a wildcard.
  fs::path root;
  for (const fs::path& part : fs::path(pattern).parent_path()) {
    if (is_glob(part.string())) break;
    root /= part;
  }
  glob_t matches{};
  const int status = ::glob(pattern.c_str(), GLOB_NOSORT, nullptr, &matches);
  std::vector<FoundFile> found;
  if (status == 0) {
    for (std::size_t i = 0; i < matches.gl_pathc; ++i) {
      const fs::path path(matches.gl_pathv[i]);
      std::error_code error;
      if (fs::is_directory(path, error)) {
        for (FoundFile& file : files_in_folder(path, extensions)) {
          found.push_back({file.path, name_below(file.path, root)});
        }
      } else if (has_extension(path, extensions)) {
        found.push_back({path.string(), name_below(path, root)});
      }
    }
  }
  ::globfree(&matches);
  if (status != 0 && status != GLOB_NOMATCH) throw io::InputError(pattern, "cannot expand the pattern");
  return found;
}

// The name with its control characters written as \xNN, for messages.
std::string printable(const std::string& name) {
  std::string text;
  for (char c : name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02x", static_cast<unsigned char>(c));
      text += escaped;
    } else {
      text += c;
    }
  }
  return text;
}

void check_safe_name(const std::string& name, const std::string& where) {
  const fs::path path(name);
  bool safe = !name.empty() && path.is_relative() && name.find('\\') == std::string::npos;
  for (const fs::path& part : path) safe = safe && part != "." && part != ".." && !part.empty();
  if (!safe) throw std::invalid_argument(where + ": job name '" + name + "' is not a relative folder name without . or ..");
  // A control character (a NUL ends the name where the file system reads it) names no folder one can see.
  if (std::any_of(name.begin(), name.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; })) {
    throw std::invalid_argument(where + ": job name '" + printable(name) + "' holds a control character");
  }
}

// What a job's description says of it, for the message of a collision.
std::string job_description(const Job& job) {
  const std::string from = job.source.empty() ? std::string() : " (" + job.source + ")";
  if (job.task) return job.task->kind() + from;
  if (!job.scene_path.empty()) return "scene " + job.scene_path + from;
  return job.request.motion_path + " onto " + job.request.character_path + from;
}

// One manifest row as text values by column, each with where it was read for errors.
struct Row {
  std::map<std::string, std::string> values;
  std::string where;                     // "m.csv: line 4" or "m.json: jobs[3]"
  std::function<std::string(const std::string&)> at;  // where column `key` was read
};

const std::set<std::string> kManifestColumns{"name", "motion", "character", "scene", "map", "source_map", "model",
                                             "quality", "fps", "parts", "bvh_units", "betas", "outputs"};

[[noreturn]] void fail(const std::string& manifest, const std::string& where, const std::string& problem) {
  throw io::InputError(manifest, where + ": " + problem);
}

Job job_from_row(const Row& row, const std::string& manifest, const JobDefaults& defaults) {
  const fs::path base = fs::path(manifest).parent_path();
  const auto get = [&](const std::string& key) -> std::optional<std::string> {
    const auto found = row.values.find(key);
    if (found == row.values.end() || found->second.empty()) return std::nullopt;
    return found->second;
  };
  const auto path_of = [&](const std::string& key) -> std::optional<std::string> {
    auto value = get(key);
    if (value && fs::path(*value).is_relative()) value = (base / *value).string();
    return value;
  };
  Job job;
  job.source = manifest + ": " + row.where;
  job.outputs = defaults.outputs;
  job.request = defaults.request;
  const auto scene = path_of("scene");
  const auto motion = path_of("motion"), character = path_of("character");
  if (scene) {
    for (const char* key : {"motion", "character", "map", "source_map", "model", "quality", "fps", "parts", "bvh_units",
                            "betas", "outputs"}) {
      if (get(key)) fail(manifest, row.at(key), "a scene row takes its settings from the scene file");
    }
    job.scene_path = *scene;
    job.name = get("name").value_or(fs::path(*scene).stem().string());
    return job;
  }
  if (!motion) fail(manifest, row.at("motion"), "missing (a row names a motion and a character, or a scene)");
  if (!character) fail(manifest, row.at("character"), "missing (a row names a motion and a character, or a scene)");
  job.request.motion_path = *motion;
  job.request.character_path = *character;
  job.name = get("name").value_or(fs::path(*character).stem().string() + "/" + fs::path(*motion).stem().string());
  if (const auto map = path_of("map")) job.request.map_path = map;
  if (const auto map = path_of("source_map")) job.request.source_map_path = map;
  if (const auto model = path_of("model")) job.request.model_path = model;
  if (const auto text = get("quality")) {
    const auto quality = retarget::parse_quality(*text);
    if (!quality) fail(manifest, row.at("quality"), "expected fast, balanced or accurate, got '" + *text + "'");
    if (*quality != job.request.quality) {
      // The batch's refinement settings are its quality's; a row of another quality takes that one's defaults.
      const int threads = job.request.refine_options.threads;
      job.request.quality = *quality;
      job.request.refine_options = retarget::default_refine_options(*quality);
      job.request.refine_options.threads = threads;
    }
  }
  if (const auto text = get("fps")) {
    std::size_t used = 0;
    double fps = 0;
    try {
      fps = std::stod(*text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text->size() || !(fps > 0) || !std::isfinite(fps) || fps > 10000) {
      fail(manifest, row.at("fps"), "expected a frame rate above 0, got '" + *text + "'");
    }
    job.request.fps = fps;
  }
  if (const auto text = get("parts")) {
    const auto parts = retarget::parse_parts(*text);
    if (!parts) fail(manifest, row.at("parts"), "expected body, body+hands or all, got '" + *text + "'");
    job.request.parts = *parts;
  }
  if (const auto text = get("bvh_units")) {
    const auto units = io::parse_bvh_units(*text);
    if (!units && *text != "auto") {
      fail(manifest, row.at("bvh_units"), "expected a BVH unit (" + std::string(io::kBvhUnitsHelp) + "), got '" + *text + "'");
    }
    job.request.bvh_metres_per_unit = units;  // auto: inferred from the skeleton's height
  }
  if (const auto text = get("betas")) {
    const auto policy = parse_betas_policy(*text);
    if (!policy) fail(manifest, row.at("betas"), std::string("expected ") + kBetasPolicyNames + ", got '" + *text + "'");
    job.request.betas = *policy;
  }
  if (const auto text = get("outputs")) {
    const auto outputs = parse_job_outputs(*text);
    if (!outputs) fail(manifest, row.at("outputs"), std::string("expected a list of ") + kJobOutputNames + ", got '" + *text + "'");
    job.outputs = *outputs;
  }
  return job;
}

std::vector<Row> rows_of_csv(const std::string& path) {
  const io::CsvTable table = io::read_csv_file(path);
  for (std::size_t c = 0; c < table.header.size(); ++c) {
    if (!kManifestColumns.count(table.header[c])) {
      std::string known;
      for (const std::string& name : kManifestColumns) known += (known.empty() ? "" : ", ") + name;
      throw io::InputError(path, "line 1, column " + std::to_string(c + 1) + ": unknown column '" + table.header[c] +
                                     "' (columns: " + known + ")");
    }
  }
  std::vector<Row> rows;
  for (const io::CsvTable::Row& record : table.rows) {
    Row row;
    row.where = "line " + std::to_string(record.line);
    for (std::size_t c = 0; c < table.header.size(); ++c) row.values[table.header[c]] = record.cells[c];
    row.at = [where = row.where](const std::string& key) { return where + ", column " + key; };
    rows.push_back(std::move(row));
  }
  return rows;
}

std::vector<Row> rows_of_json(const std::string& path) {
  const io::JsonDocument document = io::JsonDocument::read_file(path);
  const io::JsonValue root = document.root();
  io::JsonValue list = root;
  if (root.is_object()) {
    root.allow_only({"jobs"});
    list = root.member("jobs");
  }
  if (!list.is_array()) list.fail("expected an array of jobs (or an object with \"jobs\")");
  std::vector<Row> rows;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const io::JsonValue item = list[i];
    if (!item.is_object()) item.fail("expected an object naming a motion and a character, or a scene");
    Row row;
    row.where = item.path();
    for (const auto& [key, value] : item.raw().items()) {
      if (!kManifestColumns.count(key)) {
        std::string known;
        for (const std::string& name : kManifestColumns) known += (known.empty() ? "" : ", ") + name;
        item.fail("unknown key '" + key + "' (keys: " + known + ")");
      }
      const io::JsonValue field = item.member(key);
      if (field.is_string()) {
        row.values[key] = field.string();
      } else if (field.is_number()) {
        row.values[key] = value.dump();
      } else if (field.is_array() && key == "outputs") {
        std::string list_text;
        for (std::size_t k = 0; k < field.size(); ++k) list_text += (k ? "," : "") + field[k].string();
        row.values[key] = list_text;
      } else {
        field.fail("expected a string");
      }
    }
    row.at = [where = row.where](const std::string& key) { return where + "." + key; };
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace

std::optional<JobOutputs> parse_job_outputs(const std::string& list) {
  JobOutputs outputs;
  for (const auto& [name, flag] : kOutputFlags) outputs.*flag = false;
  std::size_t at = 0;
  bool any = false;
  while (at <= list.size()) {
    const std::size_t comma = std::min(list.find(',', at), list.size());
    const std::string item = list.substr(at, comma - at);
    bool known = false;
    for (const auto& [name, flag] : kOutputFlags) {
      if (item == name) outputs.*flag = known = true;
    }
    if (!known) return std::nullopt;
    any = true;
    at = comma + 1;
  }
  if (!any) return std::nullopt;
  return outputs;
}

std::string job_outputs_text(const JobOutputs& outputs) {
  std::string text;
  for (const auto& [name, flag] : kOutputFlags) {
    if (outputs.*flag) text += (text.empty() ? "" : ",") + std::string(name);
  }
  return text;
}

std::vector<FoundFile> find_input_files(const std::vector<std::string>& paths, const std::vector<std::string>& extensions,
                                        const std::string& what) {
  std::vector<FoundFile> found;
  for (const std::string& path : paths) {
    std::vector<FoundFile> files;
    std::error_code error;
    if (is_glob(path) && !fs::exists(path, error)) {
      files = files_matching(path, extensions);
      if (files.empty()) throw io::InputError(path, "the pattern matches no " + what + " file");
    } else if (fs::is_directory(path, error)) {
      files = files_in_folder(path, extensions);
      if (files.empty()) throw io::InputError(path, "the folder holds no " + what + " file");
    } else if (fs::is_regular_file(path, error)) {
      files.push_back({path, fs::path(path).stem().string()});
    } else {
      throw io::InputError(path, "no such file or folder");
    }
    std::sort(files.begin(), files.end(), [](const FoundFile& a, const FoundFile& b) { return a.path < b.path; });
    found.insert(found.end(), files.begin(), files.end());
  }
  return found;
}

std::vector<Job> cross_product_jobs(const std::vector<FoundFile>& motions, const std::vector<FoundFile>& characters,
                                    const JobDefaults& defaults) {
  std::vector<Job> jobs;
  for (const FoundFile& motion : motions) {
    for (const FoundFile& character : characters) {
      Job job;
      job.name = character.name + "/" + motion.name;
      job.source = "lists";
      job.outputs = defaults.outputs;
      job.request = defaults.request;
      job.request.motion_path = motion.path;
      job.request.character_path = character.path;
      fs::path map = fs::path(character.path);
      map.replace_extension(".map.json");
      std::error_code error;
      if (!job.request.map_path && fs::is_regular_file(map, error)) job.request.map_path = map.string();
      // A batch's BVH unit is for its BVH files, its body model for its AMASS sequences.
      if (lower(fs::path(motion.path).extension().string()) == ".bvh") {
        job.request.model_path.reset();
      } else {
        job.request.bvh_metres_per_unit.reset();
      }
      jobs.push_back(std::move(job));
    }
  }
  return jobs;
}

std::vector<Job> read_manifest(const std::string& path, const JobDefaults& defaults) {
  const std::string extension = lower(fs::path(path).extension().string());
  std::vector<Row> rows;
  if (extension == ".csv") {
    rows = rows_of_csv(path);
  } else if (extension == ".json") {
    rows = rows_of_json(path);
  } else {
    throw io::InputError(path, "a manifest is a .json or .csv file");
  }
  if (rows.empty()) throw io::InputError(path, "the manifest lists no job");
  std::vector<Job> jobs;
  std::map<std::string, std::string> first_row_of_name;
  for (const Row& row : rows) {
    Job job = job_from_row(row, path, defaults);
    try {
      check_safe_name(job.name, row.where);
    } catch (const std::invalid_argument& error) {
      throw io::InputError(path, error.what());
    }
    const auto [it, inserted] = first_row_of_name.emplace(job.name, row.where);
    if (!inserted) fail(path, row.at("name"), "job name '" + job.name + "' is also " + it->second + "'s; give the rows names");
    jobs.push_back(std::move(job));
  }
  return jobs;
}

std::string normal_job_name(const std::string& name) {
  std::string normal;
  for (const fs::path& part : fs::path(name)) {
    if (part.empty()) continue;
    normal += (normal.empty() ? "" : "/") + part.string();
  }
  return normal;
}

void check_job_names(const std::vector<Job>& jobs) {
  // By the folder each name makes: "a//b" and "a/b/" are "a/b".
  std::map<std::string, const Job*> by_name;
  for (const Job& job : jobs) {
    check_safe_name(job.name, job.source);
    const auto [it, inserted] = by_name.emplace(normal_job_name(job.name), &job);
    if (!inserted) {
      const Job& other = *it->second;
      throw std::invalid_argument("two jobs would write into " + it->first + ": " + job_description(other) + ", and " +
                                  job_description(job) + " (rename one, or list the jobs in a manifest with names)");
    }
  }
  // A job's folder must not hold another's: replacing "a/b" would take "a/b/c" with it. In name
  // order a name's descendants ("a/b/...") follow it directly, after names like "a/b-c" or "a/b.c"
  // that sort between; so look at the names after each until one no longer starts with it.
  for (auto it = by_name.begin(); it != by_name.end(); ++it) {
    for (auto next = std::next(it); next != by_name.end() && next->first.compare(0, it->first.size(), it->first) == 0; ++next) {
      if (next->first[it->first.size()] == '/') {
        throw std::invalid_argument("job " + it->first + " (" + it->second->source + ") would hold job " + next->first + " (" +
                                    next->second->source + ") in its folder; rename one");
      }
    }
  }
}

}  // namespace odyssey::batch
