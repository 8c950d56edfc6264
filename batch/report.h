// The batch's report, rendered from the journals (journal.h) so that a resumed batch, a shard and
// a merge of shards all report the same way: DIR/report.json and DIR/report.csv, one entry per
// job that finished (by name), with its status, error, frames, seconds, metrics and the gates it
// failed. Gates are applied when the report is written, so a report can be redone with others.
//
// report.json: {"batch": {settings, shards (each with its planned job count), jobs, done,
// failed, flagged, not_run, frames, job_seconds}, "gates": {...}, "jobs": [...]}.
// report.csv: one row per job; columns name, status, error, kind, motion, character, scene,
// quality, frames, seconds, flags (separated by "; "), the metrics (bone_error_mean_deg,
// bone_error_max_deg, worst_limb_mean_deg, skate, source_skate, skate_gmd, penetration_cm,
// floating_cm, jitter, source_jitter), then one column per limb (mean direction error, degrees; the union of
// the limbs of every job, sorted). Scene jobs leave the metric columns empty (their actors'
// metrics are in report.json).
#pragma once

#include <string>
#include <vector>

#include "batch/batch.h"
#include "batch/journal.h"

namespace odyssey::batch {

// Writes both files into `folder` (each atomically); returns their paths.
std::vector<std::string> write_batch_report(const std::string& folder, const JournalContents& contents, const Gates& gates);

// The journals of several output folders (the shards of one batch) as one: the last record of
// each job name. Throws io::InputError when two folders hold batches with different settings.
JournalContents merge_journals(const std::vector<std::string>& folders);

// Numbers of the report's "batch" entry.
struct ReportCounts {
  long jobs = 0, done = 0, failed = 0, flagged = 0, not_run = 0;
};
ReportCounts report_counts(const JournalContents& contents, const Gates& gates);

}  // namespace odyssey::batch
