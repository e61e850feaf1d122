#pragma once
/// \file io/detail/xml.hpp
/// \brief A small XML reader for the files io/ writes (.vtu, .pvd): elements, attributes, text,
/// comments and the prolog; no DTDs, no CDATA. A VTK `<AppendedData encoding="raw">` element ends the
/// parse: its binary content is located, not parsed.
#include <algorithm>
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mpskit/core/error.hpp"

namespace mpskit::io::detail {

/// One element.
struct xml_node {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attrs;
  std::string text;
  std::vector<xml_node> children;
  std::size_t line = 0;

  /// The attribute's value, or nullptr.
  const std::string* attr(std::string_view key) const {
    for (const auto& [k, v] : attrs)
      if (k == key) return &v;
    return nullptr;
  }
};

/// Parses `src`; errors throw mpskit::error "<what>: '<file>': line <n>: <problem>".
class xml_parser {
 public:
  xml_parser(std::string_view src, std::string what, std::string file)
      : s_(src), what_(std::move(what)), file_(std::move(file)) {}

  /// The root element. When a raw AppendedData element is met, `appended_begin()` is the offset of the
  /// first byte after its '_' marker and parsing stops there.
  xml_node parse() {
    skip_misc();
    if (!starts("<")) error("no root element");
    xml_node root = element();
    if (appended_ == npos_) {
      skip_misc();
      if (p_ != s_.size()) error("content after the root element");
    }
    return root;
  }
  std::size_t appended_begin() const { return appended_; }  ///< npos when there is none
  static constexpr std::size_t npos_ = std::string_view::npos;

  [[noreturn]] void error(std::string_view msg) {
    fail(what_, ": '", file_, "': line ", line_now(), ": ", msg);
  }

 private:
  /// Line of the current position; counted incrementally (the position only moves forward).
  std::size_t line_now() {
    const std::size_t end = std::min(p_, s_.size());
    for (; counted_ < end; ++counted_) line_ += s_[counted_] == '\n';
    return line_;
  }
  bool starts(std::string_view t) const { return s_.substr(p_, t.size()) == t; }
  static bool space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }
  void skip_space() {
    while (p_ < s_.size() && space(s_[p_])) ++p_;
  }
  void skip_until(std::string_view end, std::string_view what) {
    const std::size_t q = s_.find(end, p_);
    if (q == npos_) error(std::string("unterminated ") + std::string(what));
    p_ = q + end.size();
  }
  void skip_misc() {
    for (;;) {
      skip_space();
      if (starts("<?")) skip_until("?>", "processing instruction");
      else if (starts("<!--")) skip_until("-->", "comment");
      else return;
    }
  }
  std::string name() {
    const std::size_t b = p_;
    while (p_ < s_.size() && !space(s_[p_]) && s_[p_] != '>' && s_[p_] != '/' && s_[p_] != '=') ++p_;
    if (p_ == b) error("expected a name");
    return std::string(s_.substr(b, p_ - b));
  }
  std::string unescape(std::string_view t) {
    if (t.find('&') == std::string_view::npos) return std::string(t);
    std::string out;
    for (std::size_t k = 0; k < t.size(); ++k) {
      if (t[k] != '&') {
        out += t[k];
        continue;
      }
      const std::size_t e = t.find(';', k);
      if (e == npos_) error("bad entity");
      const std::string_view ent = t.substr(k + 1, e - k - 1);
      if (ent == "amp") out += '&';
      else if (ent == "lt") out += '<';
      else if (ent == "gt") out += '>';
      else if (ent == "quot") out += '"';
      else if (ent == "apos") out += '\'';
      else error("unknown entity &" + std::string(ent) + ";");
      k = e;
    }
    return out;
  }

  xml_node element() {
    xml_node n;
    n.line = line_now();
    ++p_;  // '<'
    n.name = name();
    for (;;) {
      skip_space();
      if (p_ >= s_.size()) error("unterminated tag <" + n.name + ">");
      if (starts("/>")) {
        p_ += 2;
        return n;
      }
      if (s_[p_] == '>') {
        ++p_;
        break;
      }
      std::string key = name();
      skip_space();
      if (p_ >= s_.size() || s_[p_] != '=') error("attribute '" + key + "' of <" + n.name + "> has no value");
      ++p_;
      skip_space();
      if (p_ >= s_.size() || (s_[p_] != '"' && s_[p_] != '\''))
        error("attribute '" + key + "' is not quoted");
      const char q = s_[p_++];
      const std::size_t e = s_.find(q, p_);
      if (e == npos_) error("unterminated value of attribute '" + key + "'");
      n.attrs.emplace_back(std::move(key), unescape(s_.substr(p_, e - p_)));
      p_ = e + 1;
    }
    if (n.name == "AppendedData") {
      const std::string* enc = n.attr("encoding");
      if (enc && *enc == "raw") {
        const std::size_t u = s_.find('_', p_);
        if (u == npos_) error("AppendedData has no '_' marker");
        appended_ = u + 1;
        return n;
      }
    }
    for (;;) {
      if (p_ >= s_.size()) error("element <" + n.name + "> is not closed (file truncated?)");
      if (starts("</")) {
        p_ += 2;
        const std::string close = name();
        skip_space();
        if (p_ >= s_.size() || s_[p_] != '>') error("bad closing tag </" + close);
        ++p_;
        if (close != n.name) error("closing tag </" + close + "> does not match <" + n.name + ">");
        return n;
      }
      if (starts("<!--")) {
        skip_until("-->", "comment");
      } else if (starts("<")) {
        n.children.push_back(element());
        if (appended_ != npos_) return n;
      } else {
        const std::size_t e = s_.find('<', p_);
        const std::size_t end = e == npos_ ? s_.size() : e;
        n.text += unescape(s_.substr(p_, end - p_));
        p_ = end;
      }
    }
  }

  std::string_view s_;
  std::string what_, file_;
  std::size_t p_ = 0;
  std::size_t appended_ = npos_;
  std::size_t counted_ = 0, line_ = 1;
};

}  // namespace mpskit::io::detail
