// Files published together (core/io.cpp).
#pragma once
#include <memory>
#include <vector>

namespace photosite {

// While an OutputSet lives, atomic_write (and so write_exr without create_only, write_png,
// write_png8) keeps each finished file under its temporary name, and commit() renames them all
// into place, in the order written. An OutputSet destroyed without commit() (an error on the
// way) removes its temporaries: nothing is published, and a signal removes them as it removes a
// write in progress. A command that writes several files for one result (night's EXR, its
// preview and the --maps pictures) so leaves all of them or none: a full disk at the preview left
// the EXR of a run that exited 2 published (thirty-fourth session; docs/cli.md "Edge cases").
// One set at a time per process; atomic_create (the device store's maps) publishes at once.
class OutputSet {
 public:
  OutputSet();
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;
  void commit();
  struct Pending;                          // a finished temporary and its target (core/io.cpp)
  void hold(std::unique_ptr<Pending> p);  // atomic_write's, while the set lives

 private:
  std::vector<std::unique_ptr<Pending>> pending_;
};

}  // namespace photosite
