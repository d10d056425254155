// Where the tests find their data: the repository's fixtures/ (RV_SOURCE_DIR, set by
// rv_add_test), the real coastlines (the Øresund, the western Baltic) included. Header-only, for
// every test folder.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace rv::test {

// The repository's top folder.
inline std::filesystem::path source_dir() {
  const char* env = std::getenv("RV_SOURCE_DIR");
  if (env != nullptr && *env != '\0') return env;
  return std::filesystem::path(__FILE__).parent_path().parent_path().parent_path();
}

// A file of the repository's fixtures/. Throws when it is not there: a test whose data is
// missing fails, it never skips.
inline std::string fixture(const std::string& name) {
  const std::filesystem::path path = source_dir() / "fixtures" / name;
  if (!std::filesystem::exists(path)) throw std::runtime_error("fixture not found: " + path.string());
  return path.string();
}

}  // namespace rv::test
