// A small JSON document tree for configuration validation (internal to config/).
//
// Built from nlohmann-json's SAX interface instead of nlohmann::json so that validation can see
// what nlohmann::json hides: every member of an object in document order, duplicate keys
// included (nlohmann::json keeps the last one silently), and the literal text of each number
// (so an error message shows "1.5" as written). Start-up only; allocates.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "config/load.hpp"

namespace hvac_twin::config::detail {

struct Member;

struct Node {
  enum class Kind { kNull, kBool, kNumber, kString, kObject, kArray };

  Kind kind = Kind::kNull;
  bool boolean = false;
  double number = 0.0;          // finite: the parser rejects numbers that overflow a double
  std::string text;             // a string's value, or a number's literal text as written
  std::vector<Member> members;  // objects, in document order, duplicate keys included
  std::vector<Node> elements;   // arrays
  std::size_t ordinal = 0;      // position in a pre-order walk: sorts errors in document order

  [[nodiscard]] bool is_object() const { return kind == Kind::kObject; }
  [[nodiscard]] bool is_array() const { return kind == Kind::kArray; }
  [[nodiscard]] bool is_string() const { return kind == Kind::kString; }
  [[nodiscard]] bool is_number() const { return kind == Kind::kNumber; }
  [[nodiscard]] bool is_bool() const { return kind == Kind::kBool; }
  // The first member named `key`, or nullptr.
  [[nodiscard]] const Node* find(std::string_view key) const;
};

struct Member {
  std::string key;
  Node value;
};

// Documents nested deeper than this are rejected (keeps the recursive walks bounded).
inline constexpr std::size_t kMaxDepth = 64;
// Documents of more values (scalars, objects and arrays) are rejected while parsing. A Node
// takes about 100 bytes: this bounds the tree near 100 MB whatever the file holds (a 15 MB
// array of zeros made 7.5 M nodes and 900 MB). 60 000 points of 13 values each still fit.
inline constexpr std::size_t kMaxValues = 1'000'000;

struct ParsedDocument {
  std::optional<Node> root;         // set when the text is well-formed JSON
  std::vector<ConfigError> errors;  // syntax errors (at most one), with line and column
};

// Parses strict JSON (RFC 8259: no comments, no trailing commas, no NaN or Infinity).
ParsedDocument parse_json(std::string_view text);

// RFC 6901: "~" -> "~0", "/" -> "~1".
std::string escape_pointer_token(std::string_view token);
std::string child_pointer(std::string_view parent, std::string_view key);
std::string child_pointer(std::string_view parent, std::size_t index);

}  // namespace hvac_twin::config::detail
