// Result<T>: a T or a std::error_code (C++20 has no std::expected), shared by the codecs of every
// drive family. Any error-code enum (std::is_error_code_enum) converts to the error side through
// its own make_error_code. value() on an error throws std::bad_variant_access.
// Thread contract: a value type; no shared state.
#pragma once

#include <system_error>
#include <type_traits>
#include <utility>
#include <variant>

namespace motion {

template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::in_place_index<0>, std::move(value)) {}     // NOLINT
  Result(std::error_code error) : state_(std::in_place_index<1>, error) {}  // NOLINT
  template <typename E>
  requires std::is_error_code_enum_v<E> Result(E error)
      : state_(std::in_place_index<1>, make_error_code(error)) {}  // NOLINT

  [[nodiscard]] bool ok() const noexcept { return state_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }
  [[nodiscard]] const T& value() const& { return std::get<0>(state_); }
  [[nodiscard]] T& value() & { return std::get<0>(state_); }
  [[nodiscard]] T&& value() && { return std::get<0>(std::move(state_)); }
  [[nodiscard]] const T& operator*() const& { return value(); }
  [[nodiscard]] const T* operator->() const { return &value(); }
  // The error, or a default (success) error_code when ok().
  [[nodiscard]] std::error_code error() const noexcept { return ok() ? std::error_code{} : std::get<1>(state_); }

 private:
  std::variant<T, std::error_code> state_;
};

}  // namespace motion
