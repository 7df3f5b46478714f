#include "config/detail/reader.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <unordered_set>
#include <utility>

namespace hvac_twin::config::detail {
namespace {

constexpr std::size_t kMaxShownChars = 48;

char lower(char c) {
  return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
}

// Optimal-string-alignment distance, case-insensitive: "prot" -> "port" is 1.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  const std::size_t n = a.size();
  const std::size_t m = b.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1, 0));
  for (std::size_t i = 0; i <= n; ++i)
    d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j)
    d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = lower(a[i - 1]) == lower(b[j - 1]) ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && lower(a[i - 1]) == lower(b[j - 2]) &&
          lower(a[i - 2]) == lower(b[j - 1]))
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[n][m];
}

bool starts_with_ci(std::string_view s, std::string_view prefix) {
  if (prefix.size() > s.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i)
    if (lower(s[i]) != lower(prefix[i])) return false;
  return true;
}

// A hint for values that look like a number written the wrong way.
std::string number_hint(const Node& n) {
  if (n.kind == Node::Kind::kNull)
    return " (null is what a NaN becomes when a JSON library writes it; write a finite number)";
  if (n.is_string()) {
    std::string_view s = n.text;
    if (!s.empty() && (s.front() == '-' || s.front() == '+')) s.remove_prefix(1);
    if (starts_with_ci(s, "nan") || starts_with_ci(s, "inf"))
      return " (JSON has no NaN or Infinity; write a finite number)";
    double parsed = 0.0;
    const auto [end, ec] = std::from_chars(n.text.data(), n.text.data() + n.text.size(), parsed);
    if (ec == std::errc() && end == n.text.data() + n.text.size())
      return " (write the number without quotes)";
  }
  return {};
}

std::string describe_type_and_range(const char* what, const Interval& allowed,
                                    std::string_view unit) {
  std::string out = what;
  if (const std::string range = allowed.describe(); !range.empty()) out += " " + range;
  if (!unit.empty()) out += " [" + std::string(unit) + "]";
  return out;
}

}  // namespace

void Errors::add(const Node& at, std::string pointer, std::string message) {
  Issue issue{at.ordinal, found_++, {std::move(pointer), std::move(message)}};
  if (issues_.size() == kMaxKeptErrors) {
    ++dropped_;
    if (!before(issue, issues_.front())) return;  // after every error kept
    std::pop_heap(issues_.begin(), issues_.end(), before);
    issues_.back() = std::move(issue);
  } else {
    issues_.push_back(std::move(issue));
  }
  std::push_heap(issues_.begin(), issues_.end(), before);
}

bool Errors::skip(const Node& at) {
  // A later error at the same value sorts after the one on top: dropped too.
  if (issues_.size() < kMaxKeptErrors || at.ordinal < issues_.front().ordinal) return false;
  ++found_;
  ++dropped_;
  return true;
}

std::vector<ConfigError> Errors::take_sorted() && {
  std::sort_heap(issues_.begin(), issues_.end(), before);
  std::vector<ConfigError> out;
  out.reserve(issues_.size());
  for (auto& issue : issues_)
    out.push_back(std::move(issue.error));
  return out;
}

Ref Ref::at(std::string_view key) const {
  if (node == nullptr || !node->is_object()) return {nullptr, child_pointer(pointer, key)};
  return {node->find(key), child_pointer(pointer, key)};
}

Ref Ref::at(std::size_t index) const {
  if (node == nullptr || !node->is_array() || index >= node->elements.size())
    return {nullptr, child_pointer(pointer, index)};
  return {&node->elements[index], child_pointer(pointer, index)};
}

bool Interval::contains(double v) const {
  const bool above = lo_open ? v > lo : v >= lo;
  const bool below = hi_open ? v < hi : v <= hi;
  return above && below;
}

std::string Interval::describe() const {
  const bool has_lo = std::isfinite(lo);
  const bool has_hi = std::isfinite(hi);
  if (has_lo && has_hi)
    return std::string("in ") + (lo_open ? "(" : "[") + format_number(lo) + ", " +
           format_number(hi) + (hi_open ? ")" : "]");
  if (has_lo) return (lo_open ? "> " : ">= ") + format_number(lo);
  if (has_hi) return (hi_open ? "< " : "<= ") + format_number(hi);
  return {};
}

std::string quote(std::string_view s) {
  return nlohmann::json(std::string(s))
      .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string describe_value(const Node& n) {
  switch (n.kind) {
    case Node::Kind::kNull:
      return "null";
    case Node::Kind::kBool:
      return n.boolean ? "true" : "false";
    case Node::Kind::kNumber:
      return n.text.size() <= kMaxShownChars ? n.text : n.text.substr(0, kMaxShownChars) + "...";
    case Node::Kind::kString:
      if (n.text.size() <= kMaxShownChars) return quote(n.text);
      return quote(n.text.substr(0, kMaxShownChars)) + "...";
    case Node::Kind::kObject:
      return "an object";
    case Node::Kind::kArray:
      return "an array";
  }
  return "?";
}

std::string quoted_list(std::span<const std::string> items) {
  std::string out;
  for (const auto& item : items)
    out += (out.empty() ? "" : ", ") + quote(item);
  return out;
}

std::string quoted_list(std::span<const std::string_view> items) {
  std::string out;
  for (const auto& item : items)
    out += (out.empty() ? "" : ", ") + quote(item);
  return out;
}

std::string format_number(double v) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  if (ec != std::errc()) return "?";
  // "1e+05" -> "1e5", "2.5e-07" -> "2.5e-7": shorter, and still a JSON number.
  std::string out(buf, end);
  if (const auto e = out.find('e'); e != std::string::npos) {
    std::size_t digits = e + 1;
    if (out[digits] == '+')
      out.erase(digits, 1);
    else if (out[digits] == '-')
      ++digits;
    while (digits + 1 < out.size() && out[digits] == '0')
      out.erase(digits, 1);
  }
  return out;
}

std::optional<std::string> did_you_mean(std::string_view word,
                                        std::span<const std::string> candidates) {
  std::optional<std::string> best;
  for (const auto& c : candidates)  // only the case differs ("kw" for "kW")
    if (c.size() == word.size() && starts_with_ci(c, word)) return c;
  if (word.size() < 3 || word.size() > 64) return best;  // too short to guess, or not a name
  const std::size_t budget = word.size() <= 4 ? 1 : (word.size() <= 8 ? 2 : 3);
  std::size_t best_distance = budget + 1;
  for (const auto& c : candidates) {
    std::size_t d = edit_distance(word, c);
    // A truncated or extended spelling ("zone_air_temp") is a near miss too.
    if (d > budget && std::min(word.size(), c.size()) >= 4 &&
        (starts_with_ci(c, word) || starts_with_ci(word, c)))
      d = budget;
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  return best;
}

std::optional<std::string> read_string(const Ref& ref, Errors& errors) {
  if (ref.node->is_string()) return ref.node->text;
  errors.add(*ref.node, ref.pointer, "expected a string; got " + describe_value(*ref.node));
  return std::nullopt;
}

std::optional<double> read_number(const Ref& ref, Errors& errors, const Interval& allowed,
                                  std::string_view unit) {
  const Node& n = *ref.node;
  if (n.is_number() && allowed.contains(n.number)) return n.number;
  errors.add(n, ref.pointer,
             "expected " + describe_type_and_range("a number", allowed, unit) + "; got " +
                 describe_value(n) + number_hint(n));
  return std::nullopt;
}

std::optional<std::int64_t> read_integer(const Ref& ref, Errors& errors, std::int64_t lo,
                                         std::int64_t hi) {
  const Node& n = *ref.node;
  const Interval allowed = closed(static_cast<double>(lo), static_cast<double>(hi));
  // Range and integrality are checked on the double; only then is it converted.
  if (n.is_number() && allowed.contains(n.number) && std::trunc(n.number) == n.number)
    return static_cast<std::int64_t>(n.number);
  errors.add(n, ref.pointer,
             "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                 "]; got " + describe_value(n) + number_hint(n));
  return std::nullopt;
}

std::optional<bool> read_bool(const Ref& ref, Errors& errors) {
  if (ref.node->is_bool()) return ref.node->boolean;
  errors.add(*ref.node, ref.pointer, "expected true or false; got " + describe_value(*ref.node));
  return std::nullopt;
}

std::optional<std::size_t> read_choice(const Ref& ref, Errors& errors,
                                       std::span<const std::string_view> choices) {
  if (ref.node->is_string()) {
    for (std::size_t i = 0; i < choices.size(); ++i)
      if (choices[i] == ref.node->text) return i;
  }
  errors.add(*ref.node, ref.pointer,
             "expected one of " + quoted_list(choices) + "; got " + describe_value(*ref.node));
  return std::nullopt;
}

std::optional<std::string> read_token(const Ref& ref, Errors& errors, bool (*allowed)(char),
                                      std::string_view charset, std::size_t max_length) {
  const Node& n = *ref.node;
  if (n.is_string() && !n.text.empty() && n.text.size() <= max_length &&
      std::all_of(n.text.begin(), n.text.end(), allowed))
    return n.text;
  errors.add(n, ref.pointer,
             "expected 1 to " + std::to_string(max_length) + " characters of " +
                 std::string(charset) + "; got " + describe_value(n));
  return std::nullopt;
}

bool is_identifier_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
}

bool is_id_char(char c) {
  return is_identifier_char(c) || c == '-';
}

ObjectReader::ObjectReader(Ref ref, Errors& errors) : ref_(std::move(ref)), errors_(errors) {
  if (!ref_.present()) return;
  ok_ = ref_.node->is_object();
  if (!ok_)
    errors_.add(*ref_.node, ref_.pointer, "expected an object; got " + describe_value(*ref_.node));
}

Ref ObjectReader::get(std::string_view key) {
  if (std::find(known_.begin(), known_.end(), key) == known_.end()) known_.emplace_back(key);
  return ok_ ? ref_.at(key) : Ref{nullptr, child_pointer(ref_.pointer, key)};
}

Ref ObjectReader::require(std::string_view key) {
  Ref r = get(key);
  if (ok_ && !r.present())
    errors_.add(*ref_.node, ref_.pointer, "missing required field " + quote(key));
  return r;
}

bool ObjectReader::number(std::string_view key, double& out, const Interval& allowed, bool required,
                          std::string_view unit) {
  const Ref r = required ? require(key) : get(key);
  if (!r.present()) return !required;
  const auto v = read_number(r, errors_, allowed, unit);
  if (v) out = *v;
  return v.has_value();
}

bool ObjectReader::boolean(std::string_view key, bool& out) {
  const Ref r = get(key);
  if (!r.present()) return true;
  const auto v = read_bool(r, errors_);
  if (v) out = *v;
  return v.has_value();
}

bool ObjectReader::string(std::string_view key, std::string& out, bool required) {
  const Ref r = required ? require(key) : get(key);
  if (!r.present()) return !required;
  const auto v = read_string(r, errors_);
  if (v) out = *v;
  return v.has_value();
}

void ObjectReader::finish() {
  if (!ok_) return;
  std::unordered_set<std::string_view> seen;
  for (const auto& m : ref_.node->members) {
    if (!seen.insert(m.key).second) continue;  // a duplicate: reported by report_duplicate_keys
    if (std::find(known_.begin(), known_.end(), m.key) != known_.end()) continue;
    if (errors_.skip(m.value)) continue;
    std::string message = "unknown key " + quote(m.key);
    if (const auto guess = did_you_mean(m.key, known_))
      message += "; did you mean " + quote(*guess) + "?";
    else
      message += "; expected one of " + quoted_list(known_);
    errors_.add(m.value, child_pointer(ref_.pointer, m.key), std::move(message));
  }
}

void report_duplicate_keys(const Ref& root, Errors& errors) {
  const Node& n = *root.node;
  if (n.is_object()) {
    std::unordered_set<std::string_view> seen;
    for (const auto& m : n.members) {
      const std::string pointer = child_pointer(root.pointer, m.key);
      if (!seen.insert(m.key).second)
        errors.add(m.value, pointer,
                   "duplicate key " + quote(m.key) +
                       "; a key may appear only once in an object (JSON parsers disagree on "
                       "which value wins)");
      report_duplicate_keys(Ref{&m.value, pointer}, errors);
    }
  } else if (n.is_array()) {
    for (std::size_t i = 0; i < n.elements.size(); ++i)
      report_duplicate_keys(Ref{&n.elements[i], child_pointer(root.pointer, i)}, errors);
  }
}

}  // namespace hvac_twin::config::detail
