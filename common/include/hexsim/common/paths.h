// Where hexsim finds its data (worlds/, data/): HEXSIM_DATA_DIR, then ../share/hexsim beside the
// executable, then the source tree it was built from.
#pragma once

#include <string>

#include "hexsim/common/status.h"

namespace hexsim {

// The software version written into every output.
const char* Version();

// The data root (holds worlds/).
std::string DataDir();

// Resolves a world file: an existing path is taken as is; otherwise a name is looked up as
// DataDir()/worlds/<kind>/<name>.yaml (kind: vehicles, environments, missions, batches).
Result<std::string> ResolveWorldFile(const std::string& kind, const std::string& name_or_path);

// Directory part of a path ("." when none) and file stem ("a/b/c.yaml" -> "c").
std::string DirName(const std::string& path);
std::string FileStem(const std::string& path);

}  // namespace hexsim
