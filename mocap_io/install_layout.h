// Where odyssey finds the files it reads at run time (the bone-map presets, the bundled data).
// `cmake --install build --prefix P` puts the binary in P/bin and those folders in
// P/share/odyssey, so a binary whose own folder has ../share/odyssey/<name> beside it is an
// installed one and reads from there, wherever it is run from and whether or not the source tree
// exists (cluster nodes run installed binaries); any other binary (the build tree's, the tests')
// reads the source tree's folder it was compiled with.
#pragma once

#include <string>

namespace odyssey::io {

// <folder of this executable>/../share/odyssey/<name> when it exists, else `build_tree_folder`.
std::string runtime_folder(const std::string& name, const std::string& build_tree_folder);

}  // namespace odyssey::io
