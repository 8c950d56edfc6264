#include "batch/batch.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <map>
#include <thread>

#include "batch/job_runner.h"
#include "batch/journal.h"
#include "batch/report.h"
#include "mocap_io/input_error.h"
#include "retarget/parts.h"
#include "scene_layouts/scene_file.h"

namespace odyssey::batch {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

const char* kVersion = "odyssey 0.1 batch 1";

std::optional<long long> whole_number(const std::string& text) {
  if (text.empty() || text.size() > 9 || text.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
  return std::stoll(text);
}

bool write_all(int fd, const std::string& text) {
  const char* data = text.data();
  std::size_t left = text.size();
  while (left > 0) {
    const ssize_t written = ::write(fd, data, left);
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) return false;
    data += written;
    left -= static_cast<std::size_t>(written);
  }
  return true;
}

// The worker's loop: a job's index per line in, its record per line out, until its input closes.
[[noreturn]] void worker_main(int in, int out, const std::vector<Job>& jobs, const BatchOptions& options,
                              const std::string& staging) {
  if (options.memory_limit_bytes > 0) {
    const rlimit limit{options.memory_limit_bytes, options.memory_limit_bytes};
    ::setrlimit(RLIMIT_AS, &limit);
  }
  scene::LoadCache cache;
  std::string buffer;
  char chunk[256];
  for (;;) {
    const std::size_t newline = buffer.find('\n');
    if (newline == std::string::npos) {
      const ssize_t got = ::read(in, chunk, sizeof chunk);
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) ::_exit(0);
      buffer.append(chunk, static_cast<std::size_t>(got));
      continue;
    }
    const std::size_t index = std::stoul(buffer.substr(0, newline));
    buffer.erase(0, newline + 1);
    nlohmann::ordered_json record = run_job(jobs.at(index), options.out, staging, cache);
    if (!write_all(out, record.dump() + "\n")) ::_exit(1);
  }
}

struct Worker {
  pid_t pid = -1;
  int to = -1, from = -1;  // the parent's ends
  std::string buffer;
  long job = -1;           // running, or -1 when idle
  Clock::time_point started;
};

std::string describe_exit(int status) {
  if (WIFSIGNALED(status)) {
    const int signal = WTERMSIG(status);
    const char* name = ::strsignal(signal);
    return "the worker died of signal " + std::to_string(signal) + " (" + (name ? name : "?") + ")" +
           (signal == SIGKILL ? ", perhaps the kernel's out-of-memory killer" : "");
  }
  return "the worker exited with code " + std::to_string(WEXITSTATUS(status)) + " before finishing the job";
}

std::size_t default_memory_limit(int workers) {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return 0;
  // 90% of the machine shared among the workers, the rest for the system and the parent.
  return static_cast<std::size_t>(0.9 * static_cast<double>(pages) * static_cast<double>(page) / std::max(1, workers));
}

// Every input file of a job: its own, and for a scene job the files its actors and props name.
std::vector<std::string> job_inputs(const Job& job) {
  if (job.task) return job.task->inputs();
  std::vector<std::string> files;
  const auto request_files = [&](const scene::RetargetRequest& request) {
    files.push_back(request.motion_path);
    files.push_back(request.character_path);
    for (const auto& path : {request.map_path, request.source_map_path, request.model_path}) {
      if (path) files.push_back(*path);
    }
  };
  if (job.scene_path.empty()) {
    request_files(job.request);
  } else {
    files.push_back(job.scene_path);
    require_regular_file(job.scene_path);  // read here, in the batch's own process
    const scene::SceneFile file = scene::read_scene_file(job.scene_path);
    for (const scene::SceneActor& actor : file.scene.actors) {
      if (const auto* request = std::get_if<scene::RetargetRequest>(&actor.source)) request_files(*request);
      if (const auto* animation = std::get_if<scene::AnimationRequest>(&actor.source)) files.push_back(animation->character_path);
      if (const auto* anime = std::get_if<scene::AnimeRequest>(&actor.source)) files.push_back(anime->path);
    }
    for (const scene::Prop& prop : file.scene.props) {
      if (!prop.path.empty()) files.push_back(prop.path);
    }
    if (file.scene.scatter) {
      for (const scene::Prop& prop : file.scene.scatter->props) {
        if (!prop.path.empty()) files.push_back(prop.path);
      }
    }
    for (const scene::SceneCamera& camera : file.scene.cameras) {
      if (const auto* rig = std::get_if<scene::FileRig>(&camera.rig)) files.push_back(rig->path);
      if (const auto* rig = std::get_if<scene::ImportedRig>(&camera.rig)) files.push_back(rig->path);
    }
  }
  std::sort(files.begin(), files.end());
  files.erase(std::unique(files.begin(), files.end()), files.end());
  return files;
}

// The paths a task job's record says it placed under DIR (only relative ones inside it).
std::vector<std::string> placed_paths(const nlohmann::json& record) {
  std::vector<std::string> paths;
  if (!record.contains("placed") || !record["placed"].is_array()) return paths;
  for (const nlohmann::json& path : record["placed"]) {
    if (!path.is_string()) continue;
    const fs::path relative(path.get<std::string>());
    if (!relative.empty() && !relative.is_absolute() && relative.lexically_normal() == relative &&
        !relative.string().starts_with("..")) {
      paths.push_back(relative.string());
    }
  }
  return paths;
}

// Whether a done job's outputs are still where its record says.
bool outputs_present(const Job& job, const nlohmann::json& record, const std::string& out) {
  if (!job.task) return fs::is_directory(fs::path(out) / "jobs" / job.name);
  const std::vector<std::string> placed = placed_paths(record);
  return !placed.empty() && std::all_of(placed.begin(), placed.end(), [&](const std::string& path) { return fs::exists(fs::path(out) / path); });
}

}  // namespace

Shard parse_shard(const std::string& text) {
  Shard shard;
  if (text == "slurm") {
    const char* id = std::getenv("SLURM_ARRAY_TASK_ID");
    const char* count = std::getenv("SLURM_ARRAY_TASK_COUNT");
    const char* minimum = std::getenv("SLURM_ARRAY_TASK_MIN");
    if (!id || !count) throw std::invalid_argument("--shard slurm: not in a Slurm job array (SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT unset)");
    const auto i = whole_number(id), n = whole_number(count), low = whole_number(minimum ? minimum : "0");
    if (!i || !n || !low || *n < 1 || *i < *low || *i - *low >= *n) {
      throw std::invalid_argument(std::string("--shard slurm: task ") + id + " of " + count + " (minimum " +
                                  (minimum ? minimum : "unset") + ") is not a shard");
    }
    shard.index = static_cast<int>(*i - *low + 1);
    shard.count = static_cast<int>(*n);
    return shard;
  }
  const std::size_t slash = text.find('/');
  const auto i = whole_number(text.substr(0, slash)), n = slash == std::string::npos ? std::nullopt : whole_number(text.substr(slash + 1));
  if (!i || !n) throw std::invalid_argument("--shard expects I/N (shard I of N, 1 <= I <= N) or slurm, got '" + text + "'");
  if (*n < 1 || *i < 1 || *i > *n) {
    throw std::invalid_argument("--shard " + text + ": I must be 1 to N and N at least 1 (shard I of N)");
  }
  shard.index = static_cast<int>(*i);
  shard.count = static_cast<int>(*n);
  return shard;
}

nlohmann::ordered_json gates_json(const Gates& gates) {
  nlohmann::ordered_json json = nlohmann::ordered_json::object();
  const auto add = [&](const char* name, const std::optional<double>& value) {
    if (value) json[name] = *value;
  };
  add("max_skate", gates.max_skate);
  add("max_bone_error_deg", gates.max_bone_error_deg);
  add("max_penetration_cm", gates.max_penetration_cm);
  add("max_floating_cm", gates.max_floating_cm);
  add("max_jitter_ratio", gates.max_jitter_ratio);
  return json;
}

std::vector<std::string> gate_flags(const nlohmann::json& metrics, const Gates& gates) {
  std::vector<std::string> flags;
  const auto check = [&](const nlohmann::json& m, const std::string& prefix) {
    const auto over = [&](const char* what, double value, const std::optional<double>& limit) {
      if (limit && value > *limit) {
        char line[160];
        std::snprintf(line, sizeof line, "%s%s %.4g > %.4g", prefix.c_str(), what, value, *limit);
        flags.push_back(line);
      }
    };
    over("skate", m.value("skate", 0.0), gates.max_skate);
    over("worst limb error deg", m.value("worst_limb_mean_deg", 0.0), gates.max_bone_error_deg);
    over("penetration cm", m.value("penetration_cm", 0.0), gates.max_penetration_cm);
    over("floating cm", m.value("floating_cm", 0.0), gates.max_floating_cm);
    const double source_jitter = m.value("source_jitter", 0.0);
    if (source_jitter > 0) over("jitter ratio", m.value("jitter", 0.0) / source_jitter, gates.max_jitter_ratio);
  };
  if (metrics.contains("actors")) {
    for (const auto& [name, m] : metrics["actors"].items()) check(m, name + ": ");
  } else if (metrics.is_object()) {
    check(metrics, "");
  }
  return flags;
}

nlohmann::ordered_json request_settings_json(const scene::RetargetRequest& request, const JobOutputs& outputs) {
  return {{"quality", retarget::quality_name(request.quality)},
          {"parts", retarget::parts_name(request.parts)},
          {"fps", request.fps},
          {"bvh_metres_per_unit", request.bvh_metres_per_unit ? nlohmann::ordered_json(*request.bvh_metres_per_unit)
                                                               : nlohmann::ordered_json("auto")},
          {"betas", betas_policy_name(request.betas)},
          {"source_rest", request.options.source_rest == retarget::SourceRest::rest ? "rest" : "first-frame"},
          {"map", request.map_path.value_or("")},
          {"source_map", request.source_map_path.value_or("")},
          {"model", request.model_path.value_or("")},
          {"refine", scene::refine_settings_json(request.refine_options)},
          {"outputs", job_outputs_text(outputs)}};
}

BatchSummary run_batch(std::vector<Job> jobs, const BatchOptions& options, const BatchProgressCallback& progress) {
  check_job_names(jobs);
  for (Job& job : jobs) job.name = normal_job_name(job.name);
  std::sort(jobs.begin(), jobs.end(), [](const Job& a, const Job& b) { return a.name < b.name; });
  std::vector<Job> mine;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    if (static_cast<int>(i % static_cast<std::size_t>(options.shard.count)) == options.shard.index - 1) {
      mine.push_back(std::move(jobs[i]));
    }
  }
  const std::string shard = options.shard.whole() ? "" : options.shard.text();
  fs::create_directories(options.out);
  Journal journal(options.out, shard, options.settings, static_cast<long>(mine.size()));
  const fs::path staging = fs::path(options.out) / ".staging" / (shard.empty() ? "whole" : "shard-" + std::to_string(options.shard.index) + "-of-" + std::to_string(options.shard.count));
  fs::remove_all(staging);
  fs::create_directories(staging);
  if (options.shard.whole()) {
    // What a killed run left of its report (the journal's lock says no other run is here).
    for (const auto& entry : fs::directory_iterator(options.out)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("report.json.partial-", 0) == 0 || name.rfind("report.csv.partial-", 0) == 0) fs::remove(entry.path());
    }
  }

  // Keys, and the jobs already done with the same key whose folder is there.
  FileHasher hasher;
  for (const auto& [name, record] : journal.records()) {
    if (record.contains("inputs") && record["inputs"].is_object()) {
      for (const auto& [path, stamp] : record["inputs"].items()) hasher.remember(path, stamp);
    }
  }
  BatchProgress counts;
  counts.total = static_cast<long>(mine.size());
  std::vector<nlohmann::ordered_json> keyed(mine.size());
  std::deque<long> pending;
  const auto start = Clock::now();
  for (std::size_t i = 0; i < mine.size(); ++i) {
    const Job& job = mine[i];
    nlohmann::ordered_json inputs = nlohmann::ordered_json::object();
    std::string key_text = kVersion;
    key_text += "\n" + job.name + "\n" + job.scene_path + "\n";
    if (job.task) {
      key_text += job.task->kind() + "\n" + job.task->key_text();
    } else if (job.scene_path.empty()) {
      key_text += request_settings_json(job.request, job.outputs).dump();
    }
    bool readable = true;
    try {
      for (const std::string& path : job_inputs(job)) {
        const nlohmann::json stamp = hasher.stamp(path);
        inputs[path] = stamp;
        key_text += "\n" + path + " " + stamp["hash"].get<std::string>();
      }
    } catch (const std::exception& error) {
      // The job runs and fails with the loader's own message.
      readable = false;
    }
    keyed[i]["key"] = readable ? hash_text(key_text) : "";
    keyed[i]["inputs"] = inputs;
    const auto found = journal.records().find(job.name);
    if (job.task && found != journal.records().end()) mine[i].previously_placed = placed_paths(found->second);
    if (readable && found != journal.records().end() && found->second.value("status", "") == "done" &&
        found->second.value("key", "") == keyed[i]["key"] && outputs_present(job, found->second, options.out)) {
      ++counts.done;
      ++counts.resumed;
      if (!gate_flags(found->second.value("metrics", nlohmann::json()), options.gates).empty()) ++counts.flagged;
      continue;
    }
    pending.push_back(static_cast<long>(i));
  }

  std::vector<Worker> workers;
  // On an exception (a progress callback that throws, a journal that cannot be written) every
  // worker is killed and reaped before it propagates; the normal path has waited for them all.
  struct Reaper {
    std::vector<Worker>& workers;
    ~Reaper() {
      for (Worker& worker : workers) {
        if (worker.pid <= 0) continue;
        ::kill(worker.pid, SIGKILL);
        ::waitpid(worker.pid, nullptr, 0);
        if (worker.to >= 0) ::close(worker.to);
        if (worker.from >= 0) ::close(worker.from);
      }
    }
  } reaper{workers};
  const std::size_t memory_limit =
      options.memory_limit_bytes > 0 ? options.memory_limit_bytes : default_memory_limit(options.workers);
  BatchOptions worker_options = options;
  worker_options.memory_limit_bytes = memory_limit;
  const auto spawn = [&]() -> Worker {
    int down[2], up[2];
    if (::pipe2(down, O_CLOEXEC) != 0 || ::pipe2(up, O_CLOEXEC) != 0) throw std::runtime_error("cannot create a pipe for a worker");
    std::fflush(nullptr);
    const pid_t parent = ::getpid();
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("cannot start a worker process");
    if (pid == 0) {
      // A worker dies with the batch (kill -9 included), so no orphan finishes a job into a folder
      // that a rerun is already using.
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(1);
      // Keep only stdio and the worker's two pipe ends (as fds 3 and 4): the journal's lock
      // among the rest must go with the batch, not linger in a worker.
      const int in = ::fcntl(down[0], F_DUPFD, 64), out = ::fcntl(up[1], F_DUPFD, 64);
      if (in < 0 || out < 0 || ::dup2(in, 3) != 3 || ::dup2(out, 4) != 4) ::_exit(1);
      ::close_range(5, ~0U, 0);
      worker_main(3, 4, mine, worker_options, staging.string());
    }
    ::close(down[0]);
    ::close(up[1]);
    Worker worker;
    worker.pid = pid;
    worker.to = down[1];
    worker.from = up[0];
    return worker;
  };
  const auto report = [&](const nlohmann::json* finished) {
    counts.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    counts.finished = finished;
    if (progress) progress(counts);
  };
  const auto finish = [&](long index, nlohmann::ordered_json result) {
    const Job& job = mine[static_cast<std::size_t>(index)];
    nlohmann::ordered_json record;
    record["job"] = job.name;
    record["key"] = keyed[static_cast<std::size_t>(index)]["key"];
    record["kind"] = job.task ? job.task->kind() : job.scene_path.empty() ? "retarget" : "scene";
    if (job.task) {
      // The task's own record says what it used.
    } else if (job.scene_path.empty()) {
      record["motion"] = job.request.motion_path;
      record["character"] = job.request.character_path;
      record["quality"] = retarget::quality_name(job.request.quality);
    } else {
      record["scene"] = job.scene_path;
    }
    for (auto& [name, value] : result.items()) record[name] = value;
    record["inputs"] = keyed[static_cast<std::size_t>(index)]["inputs"];
    if (record["status"] == "done") {
      ++counts.done;
      counts.frames += record.value("frames", 0L);
      if (!gate_flags(record.value("metrics", nlohmann::json()), options.gates).empty()) ++counts.flagged;
    } else {
      ++counts.failed;
      // Outputs of other inputs.
      std::error_code error;
      if (job.task) {
        for (const std::string& path : job.previously_placed) fs::remove_all(fs::path(options.out) / path, error);
      } else {
        fs::remove_all(fs::path(options.out) / "jobs" / job.name, error);
      }
    }
    journal.append(record);
    const nlohmann::json as_json(record);
    report(&as_json);
  };

  std::signal(SIGPIPE, SIG_IGN);  // a worker that died is noticed on its pipe, not by a signal
  const int worker_count = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(std::max(1, options.workers)), pending.size()));
  for (int w = 0; w < worker_count; ++w) workers.push_back(spawn());
  auto last_tick = Clock::now();
  for (;;) {
    // Hand out work.
    for (Worker& worker : workers) {
      if (worker.job >= 0 || pending.empty()) continue;
      worker.job = pending.front();
      pending.pop_front();
      worker.started = Clock::now();
      write_all(worker.to, std::to_string(worker.job) + "\n");
    }
    const bool busy = std::any_of(workers.begin(), workers.end(), [](const Worker& w) { return w.job >= 0; });
    if (!busy) break;
    std::vector<pollfd> polls;
    for (const Worker& worker : workers) polls.push_back({worker.from, POLLIN, 0});
    ::poll(polls.data(), polls.size(), 200);
    for (std::size_t w = 0; w < workers.size(); ++w) {
      Worker& worker = workers[w];
      bool dead = false;
      if (polls[w].revents & (POLLIN | POLLHUP | POLLERR)) {
        char chunk[65536];
        const ssize_t got = ::read(worker.from, chunk, sizeof chunk);
        if (got > 0) {
          worker.buffer.append(chunk, static_cast<std::size_t>(got));
        } else if (got == 0 || errno != EINTR) {
          dead = true;
        }
      }
      for (std::size_t newline; worker.job >= 0 && (newline = worker.buffer.find('\n')) != std::string::npos;) {
        nlohmann::ordered_json result = nlohmann::ordered_json::parse(worker.buffer.substr(0, newline), nullptr, false);
        worker.buffer.erase(0, newline + 1);
        const long job = worker.job;
        worker.job = -1;
        if (result.is_discarded()) result = {{"status", "failed"}, {"error", "the worker sent an unreadable record"}};
        finish(job, std::move(result));
      }
      const double running = std::chrono::duration<double>(Clock::now() - worker.started).count();
      const bool late = worker.job >= 0 && options.timeout_s > 0 && running > options.timeout_s;
      if (!dead && !late) continue;
      if (late) ::kill(worker.pid, SIGKILL);
      int status = 0;
      ::waitpid(worker.pid, &status, 0);
      ::close(worker.to);
      ::close(worker.from);
      worker.to = worker.from = -1;
      if (worker.job >= 0) {
        char line[128];
        std::snprintf(line, sizeof line, "timed out after %.6g s (--timeout)", options.timeout_s);
        finish(worker.job, {{"status", "failed"}, {"error", late ? std::string(line) : describe_exit(status)}, {"seconds", running}});
      }
      worker = pending.empty() ? Worker{} : spawn();
    }
    workers.erase(std::remove_if(workers.begin(), workers.end(), [](const Worker& w) { return w.pid < 0; }), workers.end());
    if (Clock::now() - last_tick > std::chrono::milliseconds(500)) {
      last_tick = Clock::now();
      report(nullptr);
    }
  }
  for (Worker& worker : workers) {
    ::close(worker.to);
    int status = 0;
    ::waitpid(worker.pid, &status, 0);
    ::close(worker.from);
  }
  workers.clear();
  std::error_code error;
  fs::remove_all(staging, error);
  fs::remove(staging.parent_path(), error);  // DIR/.staging, unless another shard is using it
  report(nullptr);

  BatchSummary summary;
  summary.counts = counts;
  // Shards of an array may share DIR and end at any time: their report is batch-report's, once all have ended.
  if (options.shard.whole()) summary.reports = write_batch_report(options.out, read_journals(options.out), options.gates);
  return summary;
}

}  // namespace odyssey::batch
