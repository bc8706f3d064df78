// The page of a report directory, index.html: the command's summary, a link to its 3-D view
// (report/view3d.h) and its pictures on one page, plain HTML with inline CSS (no scripts,
// nothing fetched).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "report/image.h"
#include "report/view3d.h"

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
/// aligned in a monospace block; omitted when empty), a link to the 3-D view's page
/// `view3d_file` (omitted when empty), then each picture with its caption, scaled down to the
/// window's width when wider.
std::string ReportIndexHtml(const std::string& title, const std::string& summary,
                            const std::vector<ReportPicture>& pictures,
                            const std::string& view3d_file = "");

/// Writes ReportIndexHtml to dir/kReportIndexFile atomically (io/atomic_file.h); returns its
/// path. Throws InputError when it cannot be written.
std::string WriteReportIndex(const std::string& dir, const std::string& title,
                             const std::string& summary, const std::vector<ReportPicture>& pictures,
                             const std::string& view3d_file = "");

/// A report directory being written: each picture as a PNG (atomically) and on the page, then
/// the page itself.
class ReportDirectory {
 public:
  explicit ReportDirectory(std::string dir) : dir_(std::move(dir)) {}
  /// Writes dir/name and adds it to the page with its caption.
  void AddPicture(const char* name, const Image& image, const std::string& caption);
  /// Writes the 3-D view (WriteView3d) and links the page to it.
  void AddView3d(const View3dScene& scene);
  /// Writes index.html; returns every file written, the page last.
  std::vector<std::string> Finish(const std::string& title, const std::string& summary);

 private:
  std::string dir_;
  std::vector<std::string> files_;
  std::vector<ReportPicture> pictures_;
  bool view3d_ = false;
};

}  // namespace rigfit
