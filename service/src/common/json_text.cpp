#include "rv/json_text.hpp"

#include "rv/field/text.hpp"

namespace rv {

nlohmann::json with_valid_utf8(const nlohmann::json& document) {
  switch (document.type()) {
    case nlohmann::json::value_t::string:
      return valid_utf8(document.get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      nlohmann::json out = nlohmann::json::array();
      for (const auto& item : document) out.push_back(with_valid_utf8(item));
      return out;
    }
    case nlohmann::json::value_t::object: {
      nlohmann::json out = nlohmann::json::object();
      // Two keys that differ only in invalid bytes stay two keys (valid_utf8 is injective on
      // invalid text). Only a valid key that spells out the escaped form of another could
      // collide with it; the keys of this product's documents are its own names.
      for (const auto& [key, value] : document.items()) out[valid_utf8(key)] = with_valid_utf8(value);
      return out;
    }
    default:
      return document;
  }
}

std::string json_text(const nlohmann::json& document, int indent) {
  try {
    return document.dump(indent);
  } catch (const nlohmann::json::type_error& e) {
    if (e.id != 316) throw;  // nothing else can fail in dump(); kept honest rather than hidden
  }
  return with_valid_utf8(document).dump(indent);
}

nlohmann::json parse_stored_json(const std::string& text) {
  nlohmann::json doc = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!doc.is_discarded() || is_valid_utf8(text)) return doc;
  // Invalid bytes can only stand inside strings of JSON text: written as "\\xHH" there, they
  // read back as the text \xHH.
  return nlohmann::json::parse(replace_invalid_utf8(text, "\\\\x"), nullptr, false);
}

}  // namespace rv
