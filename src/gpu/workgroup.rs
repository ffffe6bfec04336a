//! The kernel's workgroup and packet: sizes that the host's dispatch, its bins
//! ([`super::binning`]) and the kernel's constants ([`super::shader::host_constants`]) share.

/// Workgroup edge: the kernel's `@workgroup_size(WORKGROUP, WORKGROUP)`, and a bin's side.
pub const WORKGROUP: u32 = 8;

/// The packet of a kernel walking bins (see [`KernelConfig::packet`](super::KernelConfig::packet)).
pub const BIN_PACKET: u32 = 4;
