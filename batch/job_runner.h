// What a batch worker does with one job, in its own process (batch.h): run the job's scene into a
// staging folder, sync the files, and rename the folder onto DIR/jobs/<name>.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "batch/job.h"
#include "scene_layouts/actor.h"

namespace odyssey::batch {

// The job's record without its key and inputs (the caller adds them): status "done" with frames,
// metrics and outputs, or "failed" with the one-line error. Never throws for a bad job.
nlohmann::ordered_json run_job(const Job& job, const std::string& out, const std::string& staging,
                               scene::LoadCache& cache);

// Metrics of a retargeted actor as the report lists them.
nlohmann::ordered_json actor_metrics_json(const scene::RetargetedActor& actor);

}  // namespace odyssey::batch
