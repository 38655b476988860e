#include "cli/measured_record.h"

#include "dsp/data_file.h"
#include "dsp/record.h"

namespace panelbass::cli {

void write_measured_record(const std::string& path, double fs, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                           const Eigen::VectorXd& i, const Eigen::VectorXd& w, const Eigen::VectorXd& l) {
  dsp::Record record;
  record.fs = fs;
  record.add("u", u);
  if (y.size() == u.size()) record.add("y", y);
  if (i.size() == u.size()) record.add("i", i);
  if (w.size() == u.size()) record.add("w", w);
  if (l.size() == u.size()) record.add("l", l);
  dsp::write_data_file(path, record);
}

}  // namespace panelbass::cli
