// JSON text of the host's machine-readable answers (--print-config, --list-ports).
#pragma once

#include <string>

namespace navkit {

// `v` as a JSON string: quoted, with '"', '\\' and control characters escaped (other bytes,
// UTF-8 included, as they are).
std::string json_string(const std::string &v);

} // namespace navkit
