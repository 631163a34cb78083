// The BLAS this process runs with, and the one rule it runs under.
//
// Only CHOLMOD calls BLAS in mcvo (the supernodal Cholesky of the global
// bundle adjustment's reduced camera system; the window BA and everything
// else use Eigen). The library is whichever provides dgemm_ at run time:
// Debian's alternatives for libblas.so.3, OpenBLAS (serial) after `make deps`,
// ATLAS or the reference BLAS otherwise. All give the same solution up to
// rounding; they differ in speed (CMakeLists.txt, README "Global bundle
// adjustment").
//
// Determinism: the global BA's solver is single-threaded so that its sums
// never depend on the thread count (refine/global_ba.h). A threaded OpenBLAS
// (libopenblas0-pthread or -openmp installed in place of the serial one)
// would add threads of its own beside the pipeline's; PinBlasToOneThread()
// keeps it on the calling thread.
#pragma once

#include <string>

namespace mcvo {

// Sets a threaded OpenBLAS to one thread (openblas_set_num_threads(1), when
// the loaded BLAS has it); nothing for any other BLAS. Call once at start-up,
// before any solve.
void PinBlasToOneThread();

// The file of the shared library that provides dgemm_ in this process
// (symlinks resolved), e.g.
// "/usr/lib/x86_64-linux-gnu/openblas-serial/libopenblas-r0.3.21.so"; "" when
// no BLAS is loaded or the address cannot be traced to a file.
std::string BlasLibrary();

}  // namespace mcvo
