// A JobRecord as the stores' columns hold it: the one mapping both the SQLite and the PostgreSQL
// store read and write, so that a record reads back the same from either.
// Thread safety: free functions over values.
#pragma once

#include <array>
#include <functional>
#include <string>

#include "rv/store_jobs.hpp"

namespace rv::store {

// The record's columns, in this order, for SELECT and INSERT lists.
inline constexpr const char* kRecordColumns =
    "id, process_id, status, message, error_kind, progress, created, started, finished, updated, "
    "inputs, outputs, transmission, report, formats, principal, cells";
inline constexpr int kRecordColumnCount = 17;
inline constexpr int kProgressColumn = 5;  // integers; every other column is text
inline constexpr int kCellsColumn = 16;

// The record's column values as text (integers in decimal), in kRecordColumns' order. Messages
// are made valid UTF-8; JSON columns are compact JSON text ("" for a report not yet written).
std::array<std::string, kRecordColumnCount> record_texts(const JobRecord& r);

// The record from its columns' text (`column(i)` for i in kRecordColumns' order). Every column is
// read so that a damaged or older record still opens: the worst it can do is show an empty
// field, never fail the request (or the listing) that reads it. Text that is not UTF-8 (an older
// build's record quoting a damaged upload) is escaped on the way out.
JobRecord record_from_texts(const std::function<std::string(int)>& column);

}  // namespace rv::store
