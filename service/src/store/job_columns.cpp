#include "store/job_columns.hpp"

#include <algorithm>
#include <cstdlib>

#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/json_text.hpp"

namespace rv::store {
namespace {

// The strings of a stored JSON array; anything else (a damaged column) reads as none.
std::vector<std::string> string_list(const nlohmann::json& doc) {
  std::vector<std::string> out;
  if (!doc.is_array()) return out;
  for (const auto& item : doc)
    if (item.is_string()) out.push_back(item.get<std::string>());
  return out;
}

int64_t integer_text(const std::string& s) {
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  return end == s.c_str() ? 0 : v;
}

}  // namespace

std::array<std::string, kRecordColumnCount> record_texts(const JobRecord& r) {
  return {r.id,
          r.process_id,
          std::string(to_string(r.status)),
          valid_utf8(r.message),
          r.error_kind,
          std::to_string(r.progress),
          r.created,
          r.started,
          r.finished,
          r.updated,
          json_text(r.inputs),
          json_text(nlohmann::json(r.outputs)),
          json_text(nlohmann::json(r.transmission)),
          r.report.is_null() ? std::string() : json_text(r.report),
          json_text(nlohmann::json(r.formats)),
          r.principal,
          std::to_string(r.cells)};
}

JobRecord record_from_texts(const std::function<std::string(int)>& column) {
  auto display = [&](int i) { return valid_utf8(column(i)); };
  JobRecord r;
  r.id = display(0);
  r.process_id = display(1);
  try {
    r.status = parse_job_status(column(2));
  } catch (const Error&) {
    r.status = JobStatus::failed;
  }
  r.message = display(3);
  r.error_kind = display(4);
  r.progress = static_cast<int>(std::clamp<int64_t>(integer_text(column(kProgressColumn)), 0, 100));
  r.created = display(6);
  r.started = display(7);
  r.finished = display(8);
  r.updated = display(9);
  r.inputs = parse_stored_json(column(10));
  if (!r.inputs.is_object()) r.inputs = nlohmann::json::object();
  r.outputs = string_list(parse_stored_json(column(11)));
  r.transmission = string_list(parse_stored_json(column(12)));
  const std::string report = column(13);
  if (!report.empty()) {
    r.report = parse_stored_json(report);
    if (r.report.is_discarded()) r.report = nullptr;
  }
  r.formats = string_list(parse_stored_json(column(14)));
  r.principal = display(15);
  r.cells = std::max<int64_t>(integer_text(column(kCellsColumn)), 0);
  return r;
}

}  // namespace rv::store
