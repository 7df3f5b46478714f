#include "config/detail/json_tree.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

namespace hvac_twin::config::detail {
namespace {

using nlohmann::json;

// 1-based line and column (in bytes) of the byte at 0-based `index` of `text`.
std::pair<std::size_t, std::size_t> line_column(std::string_view text, std::size_t index) {
  index = std::min(index, text.size());
  const std::string_view before = text.substr(0, index);
  const std::size_t line =
      1 + static_cast<std::size_t>(std::count(before.begin(), before.end(), '\n'));
  const std::size_t last_newline = before.rfind('\n');
  const std::size_t column =
      last_newline == std::string_view::npos ? index + 1 : index - last_newline;
  return {line, column};
}

// nlohmann's explanation without its "[json.exception...] parse error at line L, column C: "
// prefix (we print our own position).
std::string explanation(const std::string& what) {
  std::string out = what;
  if (const auto bracket = out.find("] "); bracket != std::string::npos) out.erase(0, bracket + 2);
  if (out.rfind("parse error", 0) == 0) {
    if (const auto colon = out.find(": "); colon != std::string::npos) out.erase(0, colon + 2);
  }
  return out;
}

// Whether `text` at `index` reads "NaN" or "Inf..." (any case).
bool looks_like_nan_or_infinity(std::string_view text, std::size_t index) {
  if (index >= text.size()) return false;
  std::string word(text.substr(index, 3));
  for (char& c : word)
    c = (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
  return word == "nan" || word == "inf";
}

// Builds a Node tree from SAX events. Keeps a stack of the open containers and the pointer of
// the value being parsed, so that a number overflow can be reported at its JSON pointer.
class TreeBuilder {
 public:
  explicit TreeBuilder(std::string_view text) : text_(text) {}

  bool null() { return add_scalar(Node{}); }
  bool boolean(bool value) {
    Node n;
    n.kind = Node::Kind::kBool;
    n.boolean = value;
    return add_scalar(std::move(n));
  }
  bool number_integer(json::number_integer_t value) {
    return add_number(static_cast<double>(value), std::to_string(value));
  }
  bool number_unsigned(json::number_unsigned_t value) {
    return add_number(static_cast<double>(value), std::to_string(value));
  }
  bool number_float(json::number_float_t value, const json::string_t& literal) {
    return add_number(value, literal);
  }
  bool string(json::string_t& value) {
    Node n;
    n.kind = Node::Kind::kString;
    n.text = std::move(value);
    return add_scalar(std::move(n));
  }
  bool binary(json::binary_t& /*value*/) { return false; }  // not produced by the JSON parser

  bool start_object(std::size_t /*elements*/) { return open(Node::Kind::kObject); }
  bool end_object() { return close(); }
  bool start_array(std::size_t /*elements*/) { return open(Node::Kind::kArray); }
  bool end_array() { return close(); }

  bool key(json::string_t& key) {
    pending_key_ = std::move(key);
    return true;
  }

  bool parse_error(std::size_t position, const std::string& last_token,
                   const nlohmann::detail::exception& ex) {
    // `position` counts the bytes read, the offending one included.
    const auto [line, column] = line_column(text_, position == 0 ? 0 : position - 1);
    std::string message;
    if (text_.find_first_not_of(" \t\r\n") == std::string_view::npos) {
      message = "the document is empty; expected a JSON object";
      errors_.push_back({"", message});
      return false;
    }
    if (ex.id == 406) {  // number overflow: report it at the value's pointer
      message = "number " + last_token + " is out of range of a double (line " +
                std::to_string(line) + ", column " + std::to_string(column) + ")";
      errors_.push_back({pending_pointer(), message});
      return false;
    }
    message = "invalid JSON at line " + std::to_string(line) + ", column " +
              std::to_string(column) + ": " + explanation(ex.what());
    if (looks_like_nan_or_infinity(text_, position == 0 ? 0 : position - 1))
      message += " (JSON has no NaN or Infinity; write a finite number)";
    errors_.push_back({"", message});
    return false;
  }

  [[nodiscard]] ParsedDocument take() && {
    ParsedDocument out;
    if (errors_.empty() && done_) out.root = std::move(root_);
    out.errors = std::move(errors_);
    return out;
  }

 private:
  bool add_number(double value, std::string literal) {
    Node n;
    n.kind = Node::Kind::kNumber;
    n.number = value;
    n.text = std::move(literal);
    return add_scalar(std::move(n));
  }

  // Places `n` as the next value: the root, the next element, or the member of pending_key_.
  Node* place(Node n) {
    n.ordinal = next_ordinal_++;
    if (stack_.empty()) {
      root_ = std::move(n);
      return &root_;
    }
    Node& parent = *stack_.back();
    if (parent.is_array()) {
      parent.elements.push_back(std::move(n));
      return &parent.elements.back();
    }
    parent.members.push_back(Member{std::move(pending_key_), std::move(n)});
    pending_key_.clear();
    return &parent.members.back().value;
  }

  // Reports the value about to be placed if the document already holds kMaxValues.
  bool room() {
    if (next_ordinal_ < kMaxValues) return true;
    errors_.push_back({pending_pointer(), "more than " + std::to_string(kMaxValues) +
                                              " values in the document; a configuration is "
                                              "never this large"});
    return false;
  }

  bool add_scalar(Node n) {
    if (!room()) return false;
    place(std::move(n));
    if (stack_.empty()) done_ = true;
    return true;
  }

  bool open(Node::Kind kind) {
    if (stack_.size() >= kMaxDepth) {
      errors_.push_back({pending_pointer(), "nesting deeper than " + std::to_string(kMaxDepth) +
                                                " levels; a configuration is never this deep"});
      return false;
    }
    if (!room()) return false;
    Node n;
    n.kind = kind;
    const std::string token = pending_token();
    Node* placed = place(std::move(n));
    // The parent does not grow while this child is open, so `placed` stays valid.
    stack_.push_back(placed);
    tokens_.push_back(token);
    return true;
  }

  bool close() {
    stack_.pop_back();
    tokens_.pop_back();
    if (stack_.empty()) done_ = true;
    return true;
  }

  // The pointer token the next value will get in the innermost open container.
  [[nodiscard]] std::string pending_token() const {
    if (stack_.empty()) return {};
    const Node& parent = *stack_.back();
    return parent.is_array() ? std::to_string(parent.elements.size())
                             : escape_pointer_token(pending_key_);
  }

  [[nodiscard]] std::string pending_pointer() const {
    std::string out;
    for (std::size_t i = 1; i < tokens_.size(); ++i)
      out += "/" + tokens_[i];
    if (!stack_.empty()) out += "/" + pending_token();
    return out;
  }

  std::string_view text_;
  Node root_;
  bool done_ = false;
  std::vector<Node*> stack_;         // open containers, outermost first
  std::vector<std::string> tokens_;  // pointer token of each open container ("" for the root)
  std::string pending_key_;
  std::size_t next_ordinal_ = 0;
  std::vector<ConfigError> errors_;
};

}  // namespace

const Node* Node::find(std::string_view key) const {
  for (const auto& m : members)
    if (m.key == key) return &m.value;
  return nullptr;
}

ParsedDocument parse_json(std::string_view text) {
  TreeBuilder builder(text);
  // strict: nothing but whitespace after the value; comments are not JSON.
  json::sax_parse(text, &builder, json::input_format_t::json, /*strict=*/true,
                  /*ignore_comments=*/false);
  return std::move(builder).take();
}

std::string escape_pointer_token(std::string_view token) {
  std::string out;
  out.reserve(token.size());
  for (const char c : token) {
    if (c == '~')
      out += "~0";
    else if (c == '/')
      out += "~1";
    else
      out += c;
  }
  return out;
}

std::string child_pointer(std::string_view parent, std::string_view key) {
  return std::string(parent) + "/" + escape_pointer_token(key);
}

std::string child_pointer(std::string_view parent, std::size_t index) {
  return std::string(parent) + "/" + std::to_string(index);
}

}  // namespace hvac_twin::config::detail
