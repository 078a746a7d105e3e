#pragma once
// Big buffers backed by both threads at once.
//
// The first write to a page of fresh memory is a page fault, paid by the thread that makes it.
// std::vector's resize and assign write every element from the calling thread, so a buffer of
// hundreds of MB filled afterwards in parallel has still been faulted in serially. On the 2-core
// virtual machine of docs/scale.md a GB the host has not backed yet costs 3.2-3.7 s to fault in
// from one thread and 1.9-2.2 s from two (MADV_POPULATE_WRITE on halves of it); at sphere:9 a
// generation faults in about 3.5 GB.
#include <cstddef>
#include <vector>

namespace gshell::detail {

/// Faults in the pages of [data, data + bytes) from all threads (madvise MADV_POPULATE_WRITE per
/// chunk, Linux 5.14 on); nothing for buffers below a few MB or where the kernel cannot.
/// The contents are not changed.
void populate_in_parallel(void* data, std::size_t bytes);

/// v.assign(n, value), with v's new storage faulted in from all threads first. Drops v's old
/// storage.
template <class T> void assign_populated(std::vector<T>& v, std::size_t n, const T& value = T()) {
  std::vector<T>().swap(v);
  v.reserve(n);
  populate_in_parallel(v.data(), n * sizeof(T));
  v.assign(n, value);
}

} // namespace gshell::detail
