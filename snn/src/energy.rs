//! Energy estimates from operation counts: an SNN's synaptic operations (SynOps) and a
//! conventional network's multiply-accumulates (MACs), times published energies per operation.
//!
//! These are order-of-magnitude estimates of the arithmetic and synaptic work only: they leave
//! out neuron updates, routing between cores, memory outside the core, static power and the
//! host. The figures below are the ones the field quotes most; each names its source. They were
//! checked against how other projects quote them, not against the primary papers (no network
//! access where this was written), so read them as the literature's usual numbers.
//!
//! For the other chips the NIR export targets (Loihi 2, Speck, Xylo, SpiNNaker 2) no
//! per-SynOp energy could be verified here, so none is given: an estimate for them would be a
//! guess.

use serde::Serialize;

/// A published energy per operation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OpEnergy {
    /// Where the operation runs.
    pub platform: &'static str,
    /// What one operation is.
    pub operation: &'static str,
    pub pj_per_op: f64,
    pub source: &'static str,
}

/// Loihi (Intel, 14 nm): energy of one synaptic spike operation.
pub const LOIHI_SYNOP: OpEnergy = OpEnergy {
    platform: "Loihi (Intel, 14 nm)",
    operation: "synaptic spike operation",
    pj_per_op: 23.6,
    source: "Davies et al., Loihi: a neuromorphic manycore processor with on-chip learning, IEEE Micro 38(1), 2018, Table 1",
};

/// TrueNorth (IBM, 28 nm): energy per synaptic event.
pub const TRUENORTH_SYNOP: OpEnergy = OpEnergy {
    platform: "TrueNorth (IBM, 28 nm)",
    operation: "synaptic event",
    pj_per_op: 26.0,
    source: "Merolla et al., A million spiking-neuron integrated circuit with a scalable communication network and interface, Science 345(6197), 2014",
};

/// A 32-bit floating-point addition at 45 nm: an SNN's SynOp on general digital hardware (a
/// binary spike turns multiply-accumulate into accumulate).
pub const CMOS45_ADD: OpEnergy = OpEnergy {
    platform: "digital CMOS, 45 nm",
    operation: "32-bit float add (SNN SynOp)",
    pj_per_op: 0.9,
    source: "Horowitz, Computing's energy problem (and what we can do about it), ISSCC 2014",
};

/// A 32-bit floating-point multiply-accumulate at 45 nm (3.7 pJ multiply + 0.9 pJ add): a
/// conventional network's MAC.
pub const CMOS45_MAC: OpEnergy = OpEnergy {
    platform: "digital CMOS, 45 nm",
    operation: "32-bit float multiply-accumulate (CNN MAC)",
    pj_per_op: 4.6,
    source: "Horowitz, Computing's energy problem (and what we can do about it), ISSCC 2014",
};

/// The per-SynOp energies an SNN's estimate uses, in table order.
pub const SYNOP_ENERGIES: [OpEnergy; 3] = [LOIHI_SYNOP, TRUENORTH_SYNOP, CMOS45_ADD];

impl OpEnergy {
    /// Energy of `ops` operations, in nanojoules.
    pub fn nanojoules(&self, ops: f64) -> f64 {
        ops * self.pj_per_op * 1e-3
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nanojoules_scale_with_operations() {
        assert!((LOIHI_SYNOP.nanojoules(1000.0) - 23.6).abs() < 1e-9);
        assert!((CMOS45_MAC.nanojoules(1e6) - 4600.0).abs() < 1e-6);
        assert_eq!(CMOS45_ADD.nanojoules(0.0), 0.0);
    }
}
