// Status and Result<T>: errors a caller must look at.
//
// Bad user input (a file, a YAML field, a log) is kBadInput (CLI exit 2); numerical trouble on
// validated input (NaN, singular fit, divergence) is kNumerical (exit 3); a check the user must look
// at is kCheckFailed (exit 1). Messages follow "FILE[:LINE]: FIELD: what is wrong".
#pragma once

#include <cstdlib>
#include <optional>
#include <string>
#include <utility>
#include <variant>

namespace hexsim {

enum class StatusCode { kOk = 0, kCheckFailed = 1, kBadInput = 2, kNumerical = 3 };

class [[nodiscard]] Status {
 public:
  Status() = default;
  static Status Ok() { return Status(); }
  static Status BadInput(std::string message) { return Status(StatusCode::kBadInput, std::move(message)); }
  static Status Numerical(std::string message) { return Status(StatusCode::kNumerical, std::move(message)); }
  static Status CheckFailed(std::string message) {
    return Status(StatusCode::kCheckFailed, std::move(message));
  }

  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // Process exit code for this status (0, 1, 2, 3).
  int exit_code() const { return static_cast<int>(code_); }
  // A copy whose message is prefixed with `context: `.
  Status WithContext(const std::string& context) const;

 private:
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

// A value or the Status saying why there is none.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)) {}  // NOLINT(google-explicit-constructor)
  Result(Status status) : status_(std::move(status)) {  // NOLINT(google-explicit-constructor)
    if (status_.ok()) std::abort();  // a Result built from an OK status has no value: a bug.
  }

  bool ok() const { return value_.has_value(); }
  const Status& status() const { return status_; }
  const T& value() const& { Check(); return *value_; }
  T& value() & { Check(); return *value_; }
  T&& value() && { Check(); return std::move(*value_); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

 private:
  void Check() const {
    if (!value_) std::abort();  // reading the value of a failed Result: a bug, stays on in release.
  }
  std::optional<T> value_;
  Status status_;
};

// Returns early from the enclosing function when `expr` (a Status) is not OK.
#define HEXSIM_RETURN_IF_ERROR(expr)             \
  do {                                           \
    ::hexsim::Status hexsim_status_ = (expr);    \
    if (!hexsim_status_.ok()) return hexsim_status_; \
  } while (false)

// An invariant check that stays on in release builds.
#define HEXSIM_CHECK(cond)                                              \
  do {                                                                  \
    if (!(cond)) ::hexsim::internal::CheckFailed(#cond, __FILE__, __LINE__); \
  } while (false)

namespace internal {
[[noreturn]] void CheckFailed(const char* cond, const char* file, int line);
}  // namespace internal

}  // namespace hexsim
