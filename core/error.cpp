#include "photosite/error.h"

namespace photosite {

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
void internal_error(const std::string& message) { throw Error(message, Error::Kind::Internal); }

}  // namespace photosite
