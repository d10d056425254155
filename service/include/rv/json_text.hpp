// JSON out of the product, never an exception: the one way every entry point (the daemon's
// answers, logs and job store; the CLI's report and output) turns a document into text.
//
// nlohmann::json keeps std::string values as bytes and refuses, when dumping, any that is not
// valid UTF-8 (type_error 316). Text from outside is escaped where it enters (rv/field/text.hpp); this
// is the net behind that: a string still invalid here (a message assembled from a file name the
// user typed, a record of an older job store) is written with the same rule, valid_utf8(),
// instead of aborting the request, the worker or the process.
//
// Thread safety: pure functions.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace rv {

// document.dump(indent); a string or object key that is not valid UTF-8 is written as
// valid_utf8() of it (rv/field/text.hpp). Throws only std::bad_alloc.
std::string json_text(const nlohmann::json& document, int indent = -1);

// A copy of `document` in which every string and object key is valid UTF-8 (valid_utf8()).
nlohmann::json with_valid_utf8(const nlohmann::json& document);

// Parses JSON text that may hold bytes that are not UTF-8 (a column written by an older build):
// such bytes are escaped first. Returns a discarded value (is_discarded()) when the text is not
// JSON even then; never throws except std::bad_alloc.
nlohmann::json parse_stored_json(const std::string& text);

}  // namespace rv
