// The odyssey subcommands. Each takes the arguments after its name and returns the exit code;
// errors are thrown (InputError for bad files, UsageError for bad command lines) and reported
// by main in one line.
#pragma once

#include <string>
#include <vector>

namespace odyssey::cli {

int run_inspect(const std::vector<std::string>& arguments);
int run_pose(const std::vector<std::string>& arguments);
int run_make_body(const std::vector<std::string>& arguments);
int run_demo(const std::vector<std::string>& arguments);
int run_retarget(const std::vector<std::string>& arguments);
int run_trajectories(const std::vector<std::string>& arguments);
int run_point_cache(const std::vector<std::string>& arguments);
int run_scene(const std::vector<std::string>& arguments);
int run_batch(const std::vector<std::string>& arguments);
int run_batch_report(const std::vector<std::string>& arguments);
int run_dataset(const std::vector<std::string>& arguments);
int run_dataset_report(const std::vector<std::string>& arguments);
int run_render(const std::vector<std::string>& arguments);

}  // namespace odyssey::cli
