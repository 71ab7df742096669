// The header attributes of an OpenEXR file without its pixels (io.h's read_exr reads both): for a
// reader that decides from a file's header (photosite/unit/<channel>, photosite/cfa, ...) whether
// and how to read it.
#pragma once
#include <map>
#include <string>

namespace photosite {

// Every attribute as text, as ExrContents::attributes has them. Bad input naming the file when it
// is missing, not an OpenEXR file or its header is damaged.
std::map<std::string, std::string> read_exr_attributes(const std::string& path);

}  // namespace photosite
