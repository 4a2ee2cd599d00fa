// Enums of option structs and their names in flags and files, in one table per enum:
//   constexpr EnumName<Init> kInitNames[] = {{Init::kAuto, "auto"}, {Init::kNone, "none"}};
//   NameOf(Init::kNone, kInitNames) == "none"; FromName("pca", kInitNames) == nothing.
// The CLI turns a missing name into an InputError naming its flag (ExpectedNames lists
// the choices as "auto, none or pca").
#pragma once

#include <cstddef>
#include <optional>
#include <string>

namespace mound {

template <typename E>
struct EnumName {
  E value;
  const char* name;
};

template <typename E, size_t N>
std::string NameOf(E value, const EnumName<E> (&names)[N]) {
  for (const EnumName<E>& n : names)
    if (n.value == value) return n.name;
  return "?";
}

template <typename E, size_t N>
std::optional<E> FromName(const std::string& name, const EnumName<E> (&names)[N]) {
  for (const EnumName<E>& n : names)
    if (name == n.name) return n.value;
  return std::nullopt;
}

template <typename E, size_t N>
std::string ExpectedNames(const EnumName<E> (&names)[N]) {
  std::string s;
  for (size_t i = 0; i < N; ++i)
    s += (i == 0 ? "" : i + 1 == N ? " or " : ", ") + std::string(names[i].name);
  return s;
}

}  // namespace mound
