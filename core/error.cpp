#include "photosite/error.h"

namespace photosite {

namespace {
std::string join(const std::vector<std::string>& parts, const std::string& name) {
  std::string s;
  for (size_t i = 0; i < parts.size(); ++i) s += (i ? name : std::string()) + parts[i];
  return s;
}
}  // namespace

ParameterError::ParameterError(std::string parameter, std::vector<std::string> parts)
    : Error(join(parts, parameter), Kind::BadInput), parameter_(std::move(parameter)), parts_(std::move(parts)) {}

std::string ParameterError::message_for(const std::string& name) const { return join(parts_, name); }

std::string where(const std::string& file, int line, const std::string& key) {
  std::string s = file;
  if (line > 0) s += ":" + std::to_string(line);
  if (!key.empty()) s += ": " + key;
  return s;
}

void fail(const std::string& message) { throw Error(message, Error::Kind::BadInput); }
void fail_at(const std::string& file, const std::string& message) {
  throw Error(file + ": " + message, Error::Kind::BadInput);
}
void fail_missing(const std::string& file, const std::string& message) {
  throw MissingFileError(file + ": " + message, Error::Kind::BadInput);
}
void fail_parameter(const std::string& parameter, const std::string& before, const std::string& after) {
  throw ParameterError(parameter, {before, after});
}
void internal_error(const std::string& message) { throw Error(message, Error::Kind::Internal); }

}  // namespace photosite
