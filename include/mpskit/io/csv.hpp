#pragma once
/// \file io/csv.hpp
/// \brief CSV time series (probes, forces, integrals): a header line of "name [unit]" columns, one row
/// of doubles per call, flushed per row so a crashed run keeps every finished row.
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"

namespace mpskit::io {

/// One column: its name and SI unit ("1" for dimensionless).
struct csv_column {
  std::string name;  ///< e.g. "p_probe0"
  std::string unit;  ///< e.g. "Pa"
};

/// Opening mode of a CSV series.
enum class csv_mode : std::uint8_t {
  truncate,  ///< start a new file
  append     ///< continue an existing file (restart): its header must be the same; created when missing
};

/// \brief A CSV time-series writer: optional comment lines ("# ..."), the header "name [unit],..." then
/// rows of doubles written with the shortest representation that reads back to the same double ("nan",
/// "inf" for non-finite values).
class csv_writer {
 public:
  /// Opens `path` with these columns, after `comments` (each written as "# <line>"; on append, the
  /// existing file's comment lines are skipped); throws mpskit::error naming the path or the bad column.
  csv_writer(std::filesystem::path path, std::vector<csv_column> columns, csv_mode mode = csv_mode::truncate,
             const std::vector<std::string>& comments = {})
      : path_(std::move(path)), columns_(std::move(columns)) {
    if (columns_.empty()) fail("csv_writer '", path_.string(), "': no columns");
    std::string header;
    for (std::size_t k = 0; k < columns_.size(); ++k) {
      const auto& c = columns_[k];
      for (const std::string_view s : {std::string_view(c.name), std::string_view(c.unit)})
        if (s.empty() || s.find_first_of(",\"\n\r[]") != std::string_view::npos)
          fail("csv_writer '", path_.string(), "': column ", k, " (\"", c.name, "\" [", c.unit,
               "]): name and unit must be non-empty and contain none of , \" [ ] or a line break");
      header += (k ? "," : "") + c.name + " [" + c.unit + "]";
    }
    bool write_header = true;
    if (mode == csv_mode::append && std::filesystem::exists(path_)) {
      std::ifstream in(path_);
      std::string first;
      while (std::getline(in, first) && first.starts_with("#")) {
      }
      if (first != header)
        fail("csv_writer '", path_.string(), "': cannot append: its header \"", first, "\" differs from \"",
             header, "\"");
      write_header = false;
    }
    out_.open(path_, mode == csv_mode::append ? std::ios::app : std::ios::trunc);
    if (!out_) fail("csv_writer: cannot open '", path_.string(), "' for writing");
    if (write_header) {
      for (const auto& c : comments) {
        if (c.find_first_of("\n\r") != std::string::npos)
          fail("csv_writer '", path_.string(), "': a comment line contains a line break");
        out_ << "# " << c << '\n';
      }
      out_ << header << '\n';
      out_.flush();
      check();
    }
  }

  /// Writes one row; its width must equal the number of columns.
  void row(std::span<const double> values) {
    if (values.size() != columns_.size())
      fail("csv_writer '", path_.string(), "': row ", rows_, " has ", values.size(),
           " values, the header has ", columns_.size(), " columns");
    std::string line;
    char buf[64];
    for (std::size_t k = 0; k < values.size(); ++k) {
      if (k) line += ',';
      const auto r = std::to_chars(buf, buf + sizeof buf, values[k]);
      line.append(buf, r.ptr);
    }
    line += '\n';
    out_ << line;
    out_.flush();
    check();
    ++rows_;
  }
  /// Writes one row from a braced list.
  void row(std::initializer_list<double> values) {
    row(std::span<const double>(values.begin(), values.size()));
  }

  const std::vector<csv_column>& columns() const { return columns_; }  ///< the columns
  index_t rows() const { return rows_; }                              ///< rows written by this writer
  const std::filesystem::path& path() const { return path_; }         ///< the file

 private:
  void check() {
    if (!out_) fail("csv_writer: writing '", path_.string(), "' failed (disk full or I/O error)");
  }
  std::filesystem::path path_;
  std::vector<csv_column> columns_;
  std::ofstream out_;
  index_t rows_ = 0;
};

}  // namespace mpskit::io
