// weavefit submit: photographs through one or more weavefitd daemons.
#ifndef WEAVEFIT_CLIENT_SUBMIT_H_
#define WEAVEFIT_CLIENT_SUBMIT_H_

#include <string>
#include <vector>

#include "client/batch.h"
#include "client/rpc_client.h"

namespace weavefit {

struct SubmitFlags {
  std::vector<std::string> inputs;  // files, folders and globs (ExpandInputs)
  MetadataFlags metadata;
  std::string manifest;  // CSV manifest (ParseManifest); its images join the inputs
  bool joint = false;    // all photographs in one EstimateJoint call
  // One cylinder for all photographs (SharesCylinder), detected here
  // (ShareCylinder) and sent as each request's given cylinder.
  bool same_cylinder = false;
  bool own_cylinders = false;  // each its own, even with --joint
  Connection connection;
  std::string token_file;  // "" = $WEAVEFIT_TOKEN, if set
  int jobs = 4;            // calls in flight at once
  RetryPolicy retry;
  std::string format = "table";  // table, json or csv (stdout)
  bool json = false;             // --json: --format json
  std::string out;       // results file (.csv: CSV, else JSON lines); "" = none
  bool no_skip = false;  // estimate images whose results are in `out` again
  bool quiet = false;    // no progress or retry lines
  std::string plot_dir;  // a fit plot per image here (PlotInto); "" = none
};

// Runs the command. Stdout: the results (a table, JSON lines or CSV, in the
// inputs' order); stderr: progress (an updating line on a terminal, else one
// line per image), retries and, at the end, each failure and why. Exit
// status: 0 when every image succeeded (or was skipped), otherwise the
// status code of the first failure in input order.
int RunSubmit(SubmitFlags flags);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_SUBMIT_H_
