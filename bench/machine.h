// The machine line every benchmark table names.
#pragma once

#include <fstream>
#include <string>

namespace odyssey::bench {

// "model name" from /proc/cpuinfo, with the family and model numbers: virtual machines often
// report only a brand ("AMD EPYC"), and the numbers still tell the generation (family 26: Zen 5).
inline std::string cpu_model() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line, name = "unknown CPU", family, model;
  const auto value = [&] { return line.substr(line.find(':') + 2); };
  // The first processor's block ends at the first blank line.
  while (std::getline(cpuinfo, line) && !line.empty()) {
    if (line.rfind("model name", 0) == 0) name = value();
    if (line.rfind("cpu family", 0) == 0) family = value();
    if (line.rfind("model\t", 0) == 0) model = value();
  }
  return family.empty() ? name : name + " (family " + family + ", model " + model + ")";
}

}  // namespace odyssey::bench
