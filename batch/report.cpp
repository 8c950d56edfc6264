#include "batch/report.h"

#include <cstdio>
#include <filesystem>
#include <set>

#include "mocap_io/input_error.h"
#include "mocap_io/output_file.h"

namespace odyssey::batch {
namespace fs = std::filesystem;
namespace {

const char* const kMetricColumns[] = {"bone_error_mean_deg", "bone_error_max_deg", "worst_limb_mean_deg",
                                      "skate",               "source_skate",       "skate_gmd",
                                      "penetration_cm",      "floating_cm",        "jitter",
                                      "source_jitter"};

std::string csv_cell(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string number_cell(const nlohmann::json& value) {
  if (!value.is_number()) return "";
  if (value.is_number_integer()) return std::to_string(value.get<long long>());
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value.get<double>());
  return text;
}

std::string text_of(const nlohmann::json& record, const char* key) {
  return record.contains(key) && record[key].is_string() ? record[key].get<std::string>() : "";
}

std::string joined(const std::vector<std::string>& items) {
  std::string text;
  for (const std::string& item : items) text += (text.empty() ? "" : "; ") + item;
  return text;
}

}  // namespace

ReportCounts report_counts(const JournalContents& contents, const Gates& gates) {
  ReportCounts counts;
  long planned = 0;
  for (const nlohmann::json& header : contents.headers) planned += header.value("planned_jobs", 0L);
  for (const auto& [name, record] : contents.records) {
    ++counts.jobs;
    if (record.value("status", "") == "done") {
      ++counts.done;
      if (!gate_flags(record.value("metrics", nlohmann::json()), gates).empty()) ++counts.flagged;
    } else {
      ++counts.failed;
    }
  }
  counts.not_run = std::max(0L, planned - counts.jobs);
  return counts;
}

std::vector<std::string> write_batch_report(const std::string& folder, const JournalContents& contents, const Gates& gates) {
  const ReportCounts counts = report_counts(contents, gates);
  nlohmann::ordered_json batch;
  batch["settings"] = contents.headers.empty() ? nlohmann::json() : contents.headers[0]["settings"];
  // Shards by their spec, whichever order the journals were read in.
  std::map<std::string, long> shards;
  for (const nlohmann::json& header : contents.headers) shards[header.value("shard", "1/1")] = header.value("planned_jobs", 0L);
  batch["shards"] = nlohmann::ordered_json::array();
  for (const auto& [shard, planned] : shards) batch["shards"].push_back({{"shard", shard}, {"planned_jobs", planned}});
  batch["jobs"] = counts.jobs;
  batch["done"] = counts.done;
  batch["failed"] = counts.failed;
  batch["flagged"] = counts.flagged;
  batch["not_run"] = counts.not_run;
  long frames = 0;
  double seconds = 0;
  std::set<std::string> limbs;
  for (const auto& [name, record] : contents.records) {
    frames += record.value("frames", 0L);
    seconds += record.value("seconds", 0.0);
    if (record.contains("metrics") && record["metrics"].contains("limbs_mean_deg")) {
      for (const auto& [limb, value] : record["metrics"]["limbs_mean_deg"].items()) limbs.insert(limb);
    }
  }
  batch["frames"] = frames;
  batch["job_seconds"] = seconds;

  nlohmann::ordered_json json;
  json["batch"] = batch;
  json["gates"] = gates_json(gates);
  json["jobs"] = nlohmann::ordered_json::array();
  std::string csv = "name,status,error,kind,motion,character,scene,quality,frames,seconds,flags";
  for (const char* column : kMetricColumns) csv += std::string(",") + column;
  for (const std::string& limb : limbs) csv += "," + csv_cell(limb + "_mean_deg");
  csv += "\n";
  for (const auto& [name, record] : contents.records) {
    const nlohmann::json metrics = record.value("metrics", nlohmann::json());
    const std::vector<std::string> flags =
        record.value("status", "") == "done" ? gate_flags(metrics, gates) : std::vector<std::string>{};
    nlohmann::ordered_json entry;
    entry["name"] = name;
    for (const char* key : {"status", "error", "kind", "motion", "character", "scene", "quality", "frames", "seconds"}) {
      if (record.contains(key)) entry[key] = record[key];
    }
    entry["flags"] = flags;
    if (record.contains("metrics")) entry["metrics"] = record["metrics"];
    if (record.contains("outputs")) entry["outputs"] = record["outputs"];
    json["jobs"].push_back(entry);

    csv += csv_cell(name);
    for (const char* key : {"status", "error", "kind", "motion", "character", "scene", "quality"}) csv += "," + csv_cell(text_of(record, key));
    csv += "," + number_cell(record.value("frames", nlohmann::json())) + "," + number_cell(record.value("seconds", nlohmann::json()));
    csv += "," + csv_cell(joined(flags));
    const bool single = metrics.is_object() && !metrics.contains("actors");
    for (const char* column : kMetricColumns) csv += "," + (single ? number_cell(metrics.value(column, nlohmann::json())) : "");
    for (const std::string& limb : limbs) {
      csv += ",";
      if (single && metrics.contains("limbs_mean_deg")) csv += number_cell(metrics["limbs_mean_deg"].value(limb, nlohmann::json()));
    }
    csv += "\n";
  }
  const std::string json_path = (fs::path(folder) / "report.json").string();
  const std::string csv_path = (fs::path(folder) / "report.csv").string();
  io::StagedOutputs staged;
  io::write_file_atomically(staged.stage(json_path), json.dump(2) + "\n");
  io::write_file_atomically(staged.stage(csv_path), csv);
  staged.commit();
  return {json_path, csv_path};
}

JournalContents merge_journals(const std::vector<std::string>& folders) {
  JournalContents merged;
  std::string first;
  for (const std::string& folder : folders) {
    JournalContents contents = read_journals(folder);
    if (!merged.headers.empty() && contents.headers[0]["settings"] != merged.headers[0]["settings"]) {
      throw io::InputError(folder, "holds the journal of another batch than " + first + " (its settings differ)");
    }
    if (first.empty()) first = folder;
    for (auto& header : contents.headers) merged.headers.push_back(std::move(header));
    for (auto& [name, record] : contents.records) merged.records[name] = std::move(record);
  }
  return merged;
}

}  // namespace odyssey::batch
