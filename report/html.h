// The page of a report directory, index.html: the command's summary and its pictures on one
// page, plain HTML with inline CSS (no scripts, nothing fetched).
#pragma once

#include <string>
#include <vector>

namespace rigfit {

/// The page's file name in a report directory.
inline constexpr const char* kReportIndexFile = "index.html";

/// One picture of the page: a PNG in the same directory.
struct ReportPicture {
  std::string file;  ///< name relative to the page, e.g. "residuals.png"
  std::string caption;
  int width = 0;  ///< pixels
  int height = 0;
};

/// `text` with &, <, >, " and ' written as character references: safe as element text and
/// as a quoted attribute value.
std::string HtmlEscape(const std::string& text);

/// The page: `title` as heading, `summary` (the text the command printed, its tables kept
/// aligned in a monospace block; omitted when empty), then each picture with its caption,
/// scaled down to the window's width when wider.
std::string ReportIndexHtml(const std::string& title, const std::string& summary,
                            const std::vector<ReportPicture>& pictures);

/// Writes ReportIndexHtml to dir/kReportIndexFile atomically (io/atomic_file.h); returns its
/// path. Throws InputError when it cannot be written.
std::string WriteReportIndex(const std::string& dir, const std::string& title,
                             const std::string& summary,
                             const std::vector<ReportPicture>& pictures);

}  // namespace rigfit
