//! The MPI halo transport: ghost strips point to point between ranks.

use super::HaloTransport;
use crate::error::{Error, Result};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// Tag of halo strips.
const TAG_HALO: i32 = 21;
/// Tag of finished tiles (rank -> rank 0).
const TAG_FINAL: i32 = 22;

/// Halo exchange over `MPI_COMM_WORLD` (the ranks of the MPI engine):
/// each round posts every receive and send without blocking
/// (MPI_Irecv/MPI_Isend) and waits for all, so the order of peers
/// cannot deadlock.
pub struct MpiHalo {
    comm: SimpleCommunicator,
}

impl MpiHalo {
    /// The transport of the running MPI engine (`--engine mpi`).
    pub fn new() -> Result<Self> {
        if !crate::exec::mpi::active() {
            return Err(Error::invalid(
                "halo exchange over MPI: the MPI engine is not running (--engine mpi)",
            ));
        }
        Ok(MpiHalo {
            comm: SimpleCommunicator::world(),
        })
    }
}

fn count_ok(n: usize) -> Result<()> {
    if n > i32::MAX as usize {
        return Err(Error::invalid(format!(
            "halo exchange: a message of {n} values is over MPI's 2^31 count limit; use smaller tiles (--tile) or a smaller --exchange"
        )));
    }
    Ok(())
}

impl HaloTransport for MpiHalo {
    fn rank(&self) -> (usize, usize) {
        (
            self.comm.rank().max(0) as usize,
            self.comm.size().max(1) as usize,
        )
    }
    fn distributed(&self) -> bool {
        true
    }
    fn exchange(&mut self, out: &[Vec<f64>], inbox: &mut [Vec<f64>]) -> Result<()> {
        for v in out.iter().chain(inbox.iter()) {
            count_ok(v.len())?;
        }
        let comm = &self.comm;
        mpi::request::scope(|scope| {
            let mut recvs = Vec::new();
            for (p, buf) in inbox.iter_mut().enumerate() {
                if !buf.is_empty() {
                    recvs.push(
                        comm.process_at_rank(p as i32)
                            .immediate_receive_into_with_tag(scope, &mut buf[..], TAG_HALO),
                    );
                }
            }
            let mut sends = Vec::new();
            for (q, buf) in out.iter().enumerate() {
                if !buf.is_empty() {
                    sends.push(comm.process_at_rank(q as i32).immediate_send_with_tag(
                        scope,
                        &buf[..],
                        TAG_HALO,
                    ));
                }
            }
            for r in recvs {
                r.wait_without_status();
            }
            for s in sends {
                s.wait_without_status();
            }
        });
        Ok(())
    }
    fn send_to_root(&mut self, data: &[f64]) -> Result<()> {
        count_ok(data.len())?;
        self.comm.process_at_rank(0).send_with_tag(data, TAG_FINAL);
        Ok(())
    }
    fn recv_from(&mut self, from: usize, buf: &mut [f64]) -> Result<()> {
        count_ok(buf.len())?;
        let status = self
            .comm
            .process_at_rank(from as i32)
            .receive_into_with_tag(buf, TAG_FINAL);
        let got = status.count(f64::equivalent_datatype());
        if got as usize != buf.len() {
            return Err(Error::invalid(format!(
                "halo exchange: rank {from} sent a tile of {got} values, expected {}",
                buf.len()
            )));
        }
        Ok(())
    }
    fn send_to_root_f32(&mut self, data: &[f32]) -> Result<()> {
        count_ok(data.len())?;
        self.comm.process_at_rank(0).send_with_tag(data, TAG_FINAL);
        Ok(())
    }
    fn recv_from_f32(&mut self, from: usize, buf: &mut [f32]) -> Result<()> {
        count_ok(buf.len())?;
        let status = self
            .comm
            .process_at_rank(from as i32)
            .receive_into_with_tag(buf, TAG_FINAL);
        let got = status.count(f32::equivalent_datatype());
        if got as usize != buf.len() {
            return Err(Error::invalid(format!(
                "halo exchange: rank {from} sent a tile of {got} f32 values, expected {}",
                buf.len()
            )));
        }
        Ok(())
    }
    fn sum(&mut self, v: &[u64]) -> Result<Vec<u64>> {
        let n = self.comm.size().max(1) as usize;
        let mut all = vec![0u64; v.len() * n];
        self.comm.all_gather_into(v, &mut all[..]);
        let mut s = vec![0u64; v.len()];
        for chunk in all.chunks_exact(v.len().max(1)) {
            for (a, b) in s.iter_mut().zip(chunk) {
                *a += b;
            }
        }
        Ok(s)
    }
    fn all_gather(&mut self, v: &[f64]) -> Result<Vec<Vec<f64>>> {
        use mpi::datatype::PartitionMut;
        count_ok(v.len())?;
        let n = self.comm.size().max(1) as usize;
        let mut counts = vec![0i32; n];
        self.comm
            .all_gather_into(&(v.len() as i32), &mut counts[..]);
        let total: usize = counts.iter().map(|&c| c as usize).sum();
        count_ok(total)?;
        let displs: Vec<i32> = counts
            .iter()
            .scan(0i32, |acc, &c| {
                let d = *acc;
                *acc += c;
                Some(d)
            })
            .collect();
        let mut all = vec![0f64; total];
        {
            let mut part = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
            self.comm.all_gather_varcount_into(v, &mut part);
        }
        Ok(counts
            .iter()
            .zip(&displs)
            .map(|(&c, &d)| all[d as usize..(d + c) as usize].to_vec())
            .collect())
    }
    fn barrier(&mut self) {
        self.comm.barrier();
    }
    fn fail(&self, e: Error) -> Error {
        crate::exec::mpi::abort(&e.to_string())
    }
}
