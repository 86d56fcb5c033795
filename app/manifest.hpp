#pragma once
// Manifests: text files listing shot files, one path a line, so that a batch
// scheduler (a Slurm job array, xargs -P, GNU parallel) can hand each task a
// fixed slice of a campaign spread over many folders (docs/cluster.md).
//
//   # comment lines and blank lines are ignored
//   /data/campaign-a/20260314-101500-0001.h5
//   campaign-b/20260314-111500-0001.h5      <- relative: to the manifest's folder
//
// Shots are numbered 0.. over the path lines only; task I with chunk K takes
// shots [I*K, (I+1)*K), the last task maybe fewer.
#include <string>
#include <vector>

#include "analysis/result.hpp"

namespace collide::app {

struct ManifestEntry {
  std::string path;  ///< as resolved (absolute if the manifest's folder is)
  int line = 0;      ///< 1-based line in the manifest, for messages
};

/// Reads a manifest. Errors: the file is missing or unreadable, it lists no
/// shot file, a line holds a NUL or control character (not a text file).
Result<std::vector<ManifestEntry>> readManifest(const std::string& manifest_path);

/// The entries task `index` analyses with `chunk` shots per task. Errors, in
/// words naming the manifest: chunk < 1, index < 0, an index past the end
/// (saying how many tasks the manifest needs, e.g. --array=0-9).
Result<std::vector<ManifestEntry>> manifestChunk(const std::vector<ManifestEntry>& entries,
                                                 const std::string& manifest_path, long index,
                                                 long chunk);

/// How many tasks of `chunk` shots cover `shots` shots.
long tasksFor(long shots, long chunk);

/// Every shot file (*.h5, not hidden) in `folders`, each folder's in name
/// order, as absolute paths: a manifest's lines. Errors: a folder missing or
/// without shot files (named).
Result<std::vector<std::string>> listShotFiles(const std::vector<std::string>& folders);

}  // namespace collide::app
