// Escaping text for HTML and XML (KML) documents: the five characters with markup meaning
// become entities, using only forms both languages define (&#39; for the apostrophe).
#pragma once

#include <string>
#include <string_view>

namespace ridgeline::io {

inline std::string escape_markup(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace ridgeline::io
