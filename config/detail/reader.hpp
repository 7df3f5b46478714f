// Typed, error-collecting access to a parsed JSON tree (internal to config/).
//
// Every reader reports what is wrong as a ConfigError at the offending value's JSON pointer and
// returns whether the value is usable, so that one pass finds every error and cross-checks can
// skip values already reported (no cascades of follow-up errors).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "config/detail/json_tree.hpp"
#include "config/load.hpp"

namespace hvac_twin::config::detail {

// Errors with the document position of the value they are about. Keeps the first
// kMaxKeptErrors in document order (a heap ordered by position) and counts the others, so that a
// file of a million unknown keys does not hold a million messages.
class Errors {
 public:
  void add(const Node& at, std::string pointer, std::string message);
  // Counts an error at `at` and returns true if add() would drop it: the caller then need not
  // build its message (a hostile file's millionth unknown key costs no edit distances).
  bool skip(const Node& at);
  [[nodiscard]] bool empty() const { return issues_.empty(); }
  [[nodiscard]] std::size_t dropped() const { return dropped_; }  // found, not kept
  // The errors kept, in document order (ties keep the order they were found in).
  [[nodiscard]] std::vector<ConfigError> take_sorted() &&;

 private:
  struct Issue {
    std::size_t ordinal;
    std::size_t found;  // ties at one value: the order they were found in
    ConfigError error;
  };
  static bool before(const Issue& a, const Issue& b) {
    return a.ordinal != b.ordinal ? a.ordinal < b.ordinal : a.found < b.found;
  }
  std::vector<Issue> issues_;  // a max-heap by before(): the last error kept on top
  std::size_t found_ = 0;
  std::size_t dropped_ = 0;
};

// A value of the document and its pointer; node == nullptr when the value is absent.
struct Ref {
  const Node* node = nullptr;
  std::string pointer;

  [[nodiscard]] bool present() const { return node != nullptr; }
  [[nodiscard]] Ref at(std::string_view key) const;  // member (absent if not an object)
  [[nodiscard]] Ref at(std::size_t index) const;     // element (absent if not an array)
};

// An allowed numeric interval; an open end excludes the bound itself.
struct Interval {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;

  [[nodiscard]] bool contains(double v) const;
  [[nodiscard]] std::string describe() const;  // "in [1, 65535]", "> 0", "in (0, 3600]", ""
};
inline Interval closed(double lo, double hi) {
  return {lo, hi, false, false};
}
inline Interval positive(double hi = std::numeric_limits<double>::infinity()) {
  return {0.0, hi, true, false};
}
inline Interval at_least(double lo) {
  return {lo, std::numeric_limits<double>::infinity(), false, false};
}
inline Interval any_finite() {
  return {};
}

// What a value is when it is wrong: "70000", "\"float\"", "an object", "null" (short, one line).
std::string describe_value(const Node& n);
// A JSON string literal for `s` (quoted, escaped), for messages.
std::string quote(std::string_view s);
// "\"a\", \"b\", \"c\"".
std::string quoted_list(std::span<const std::string> items);
std::string quoted_list(std::span<const std::string_view> items);
// Shortest decimal form that reads back as `v` ("0.25", "1e+09").
std::string format_number(double v);
// The candidate closest to `word` if it is a plausible misspelling, else nullopt.
std::optional<std::string> did_you_mean(std::string_view word,
                                        std::span<const std::string> candidates);

// Each check reports an error at `ref` and returns nullopt when the value is unusable.
// `ref` must be present.
std::optional<std::string> read_string(const Ref& ref, Errors& errors);
std::optional<double> read_number(const Ref& ref, Errors& errors, const Interval& allowed,
                                  std::string_view unit = {});
// Integral and inside `allowed` before any conversion (1.5 and 3000000000 are errors, not 1 and
// -1294967296). 502.0 is accepted as 502.
std::optional<std::int64_t> read_integer(const Ref& ref, Errors& errors, std::int64_t lo,
                                         std::int64_t hi);
std::optional<bool> read_bool(const Ref& ref, Errors& errors);
// One of `choices`; returns its index.
std::optional<std::size_t> read_choice(const Ref& ref, Errors& errors,
                                       std::span<const std::string_view> choices);
// A non-empty string of at most `max_length` characters from `charset` (e.g. "[A-Za-z0-9_]"),
// where `allowed(c)` says which characters belong to it.
std::optional<std::string> read_token(const Ref& ref, Errors& errors, bool (*allowed)(char),
                                      std::string_view charset, std::size_t max_length);

bool is_identifier_char(char c);  // [A-Za-z0-9_]
bool is_id_char(char c);          // [A-Za-z0-9_-]

// Reads the members of one object: the caller asks for each key it knows; finish() reports every
// other key as unknown (with a suggestion for near misses). Duplicate keys are reported once for
// the whole document by report_duplicate_keys(); get() returns the first occurrence.
class ObjectReader {
 public:
  // Reports "expected an object" if `ref` is present and not an object.
  ObjectReader(Ref ref, Errors& errors);
  ObjectReader(const ObjectReader&) = delete;
  ObjectReader& operator=(const ObjectReader&) = delete;
  ~ObjectReader() = default;

  [[nodiscard]] bool ok() const { return ok_; }  // present and an object
  [[nodiscard]] const Ref& ref() const { return ref_; }
  [[nodiscard]] Errors& errors() const { return errors_; }

  // The member `key` (absent if missing); marks `key` as known.
  Ref get(std::string_view key);
  // As get(), but a missing member is an error at this object: missing required field "key".
  Ref require(std::string_view key);

  // Typed optional fields: leave `out` unchanged when absent; return false when present and
  // invalid (the error is reported). Typed required fields: also false when absent.
  bool number(std::string_view key, double& out, const Interval& allowed, bool required = false,
              std::string_view unit = {});
  template <class Int>
  bool integer(std::string_view key, Int& out, std::int64_t lo, std::int64_t hi,
               bool required = false) {
    const Ref r = required ? require(key) : get(key);
    if (!r.present()) return !required;
    const auto v = read_integer(r, errors_, lo, hi);
    if (v) out = static_cast<Int>(*v);
    return v.has_value();
  }
  bool boolean(std::string_view key, bool& out);
  bool string(std::string_view key, std::string& out, bool required = false);
  template <class Enum>
  bool choice(std::string_view key, Enum& out, std::span<const std::string_view> names,
              std::span<const Enum> values) {
    const Ref r = get(key);
    if (!r.present()) return true;
    const auto i = read_choice(r, errors_, names);
    if (i) out = values[*i];
    return i.has_value();
  }

  // Reports the keys nobody asked for. Call once, after the last get().
  void finish();

 private:
  Ref ref_;
  Errors& errors_;
  bool ok_ = false;
  std::vector<std::string> known_;
};

// Reports every duplicate key anywhere in the tree (all but the first occurrence are errors).
void report_duplicate_keys(const Ref& root, Errors& errors);

}  // namespace hvac_twin::config::detail
