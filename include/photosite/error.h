// Errors travel as exceptions carrying what went wrong and where (file, line, key). The library
// says what kind of error it is; the faces decide what that means to their users: the command
// line (cli/main.cpp) maps bad input to exit status 2 and internal errors to 1, the Python module
// to ValueError and RuntimeError.
#pragma once
#include <stdexcept>
#include <string>
#include <vector>

namespace photosite {

class Error : public std::runtime_error {
 public:
  enum class Kind { BadInput, Internal };
  explicit Error(const std::string& message, Kind kind = Kind::BadInput)
      : std::runtime_error(message), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

// Bad input in one named parameter of the library's API ("shard", "label_format", "backend"):
// what() names it with the library's spelling, and each face re-words the message with its own
// (the command line's --label-format, a Python keyword) through message_for(). The message is
// kept as the text between the mentions of the name: parts {"unknown ", " 'x'"} read
// "unknown shard 'x'" and, on the command line, "unknown --shard 'x'".
class ParameterError : public Error {
 public:
  ParameterError(std::string parameter, std::vector<std::string> parts);
  const std::string& parameter() const { return parameter_; }
  const std::vector<std::string>& parts() const { return parts_; }
  // The message with the parameter called `name`.
  std::string message_for(const std::string& name) const;

 private:
  std::string parameter_;
  std::vector<std::string> parts_;
};

// Bad input that is a missing input file ("file: message"): the command line treats it as any bad
// input (exit status 2); the Python module raises FileNotFoundError for it, ValueError for the rest.
class MissingFileError : public Error {
 public:
  using Error::Error;
};

// "file:line: key: problem" — the form every preset and input error takes.
std::string where(const std::string& file, int line = 0, const std::string& key = {});

[[noreturn]] void fail(const std::string& message);                        // BadInput
[[noreturn]] void fail_at(const std::string& file, const std::string& message);  // "file: message"
// MissingFileError "file: message": `file` does not exist.
[[noreturn]] void fail_missing(const std::string& file, const std::string& message);
// ParameterError: before + <parameter> + after.
[[noreturn]] void fail_parameter(const std::string& parameter, const std::string& before,
                                 const std::string& after = {});
[[noreturn]] void internal_error(const std::string& message);

}  // namespace photosite
