// Errors travel as exceptions carrying what went wrong and where (file, line, key); the CLI turns
// them into a message and an exit status: 2 for bad input, 1 for internal errors.
#pragma once
#include <stdexcept>
#include <string>

namespace photosite {

class Error : public std::runtime_error {
 public:
  enum class Kind { BadInput, Internal };
  explicit Error(const std::string& message, Kind kind = Kind::BadInput)
      : std::runtime_error(message), kind_(kind) {}
  Kind kind() const { return kind_; }
  int exit_code() const { return kind_ == Kind::BadInput ? 2 : 1; }

 private:
  Kind kind_;
};

// "file:line: key: problem" — the form every preset and input error takes.
std::string where(const std::string& file, int line = 0, const std::string& key = {});

[[noreturn]] void fail(const std::string& message);                        // BadInput
[[noreturn]] void fail_at(const std::string& file, const std::string& message);  // "file: message"
[[noreturn]] void internal_error(const std::string& message);

}  // namespace photosite
