// odyssey make-body: the synthetic SMPL-X body model, so everything runs without the licensed file.
#include <cstdio>

#include "cli/args.h"
#include "cli/commands.h"
#include "mocap_io/body_model_writer.h"
#include "mocap_io/output_file.h"
#include "synthetic/synthetic_body.h"

namespace odyssey::cli {

int run_make_body(const std::vector<std::string>& arguments) {
  Args args("make-body",
            "Write a synthetic 1.7 m T-pose humanoid in exactly the SMPL-X npz layout of the smplx package\n"
            "(10,475 vertices, 20,908 triangles, 55 joints, 300 shape + 100 expression directions, 486\n"
            "pose-corrective directions, hand PCA, landmarks). Deterministic for a seed.");
  args.option("out", "FILE", "output npz")
      .option("seed", "N", "random seed for proportions and directions", "0")
      .flag("dense", "fill pose correctives on every vertex and spread weights over up to 8 joints, like the "
                     "licensed model (for benchmarks; a much larger file)");
  if (!args.parse(arguments)) return 0;
  const std::string out = args.get("out");
  io::require_replaceable_output(out);
  const long long seed = args.get_int("seed");
  if (seed < 0 || seed > 0xffffffffLL) throw UsageError("--seed must be between 0 and 4294967295");
  const SyntheticBody body = make_synthetic_body(static_cast<unsigned>(seed), args.get_flag("dense"));
  io::write_body_model(out, body);
  std::printf("wrote %s: synthetic SMPL-X body, %d vertices, %lld faces, %d joints (seed %lld)\n", out.c_str(),
              body.model.vertex_count(), static_cast<long long>(body.model.faces.rows()), body.model.joint_count(), seed);
  return 0;
}

}  // namespace odyssey::cli
