//! Ranks simulated by threads, for tests of the ranked drivers without MPI.

use super::HaloTransport;
use crate::error::{Error, Result};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Barrier};

/// Ranks simulated by threads: one FIFO channel per ordered pair of
/// ranks (the driver's messages between two ranks are received in the
/// order they are sent, as MPI guarantees for one source and tag).
pub(crate) struct Chan {
    pub(crate) me: usize,
    n: usize,
    tx: Vec<Sender<Vec<f64>>>,
    rx: Vec<Receiver<Vec<f64>>>,
    barrier: Arc<Barrier>,
}

pub(crate) fn chans(n: usize) -> Vec<Chan> {
    let mut tx: Vec<Vec<Option<Sender<Vec<f64>>>>> = (0..n).map(|_| vec![None; n]).collect();
    let mut rx: Vec<Vec<Option<Receiver<Vec<f64>>>>> =
        (0..n).map(|_| (0..n).map(|_| None).collect()).collect();
    for (p, txp) in tx.iter_mut().enumerate() {
        for (q, t) in txp.iter_mut().enumerate() {
            let (s, r) = channel();
            *t = Some(s);
            rx[q][p] = Some(r);
        }
    }
    let barrier = Arc::new(Barrier::new(n));
    tx.into_iter()
        .zip(rx)
        .enumerate()
        .map(|(me, (t, r))| Chan {
            me,
            n,
            tx: t.into_iter().map(|s| s.unwrap()).collect(),
            rx: r.into_iter().map(|s| s.unwrap()).collect(),
            barrier: barrier.clone(),
        })
        .collect()
}

impl Chan {
    fn recv(&self, from: usize, buf: &mut [f64]) -> Result<()> {
        let v = self.rx[from]
            .recv()
            .map_err(|_| Error::invalid(format!("rank {from} hung up")))?;
        if v.len() != buf.len() {
            return Err(Error::invalid(format!(
                "rank {} got {} values from {from}, expected {}",
                self.me,
                v.len(),
                buf.len()
            )));
        }
        buf.copy_from_slice(&v);
        Ok(())
    }
}

impl HaloTransport for Chan {
    fn rank(&self) -> (usize, usize) {
        (self.me, self.n)
    }
    fn distributed(&self) -> bool {
        false
    }
    fn exchange(&mut self, out: &[Vec<f64>], inbox: &mut [Vec<f64>]) -> Result<()> {
        for (q, v) in out.iter().enumerate() {
            if !v.is_empty() {
                self.tx[q]
                    .send(v.clone())
                    .map_err(|_| Error::invalid("peer gone"))?;
            }
        }
        for (p, buf) in inbox.iter_mut().enumerate() {
            if !buf.is_empty() {
                self.recv(p, buf)?;
            }
        }
        Ok(())
    }
    fn send_to_root(&mut self, data: &[f64]) -> Result<()> {
        self.tx[0]
            .send(data.to_vec())
            .map_err(|_| Error::invalid("rank 0 gone"))
    }
    fn recv_from(&mut self, from: usize, buf: &mut [f64]) -> Result<()> {
        self.recv(from, buf)
    }
    // The test channel carries f64: f32 values widened (exact) and back.
    fn send_to_root_f32(&mut self, data: &[f32]) -> Result<()> {
        self.tx[0]
            .send(data.iter().map(|&v| f64::from(v)).collect())
            .map_err(|_| Error::invalid("rank 0 gone"))
    }
    fn recv_from_f32(&mut self, from: usize, buf: &mut [f32]) -> Result<()> {
        let mut wide = vec![0.0f64; buf.len()];
        self.recv(from, &mut wide)?;
        for (d, s) in buf.iter_mut().zip(&wide) {
            *d = *s as f32;
        }
        Ok(())
    }
    fn sum(&mut self, v: &[u64]) -> Result<Vec<u64>> {
        // Exact for the counts the drivers sum (below 2^53).
        let wide: Vec<f64> = v.iter().map(|&c| c as f64).collect();
        let all = self.all_gather(&wide)?;
        Ok((0..v.len())
            .map(|i| all.iter().map(|m| m[i] as u64).sum())
            .collect())
    }
    fn all_gather(&mut self, v: &[f64]) -> Result<Vec<Vec<f64>>> {
        for q in 0..self.n {
            if q != self.me {
                self.tx[q]
                    .send(v.to_vec())
                    .map_err(|_| Error::invalid("peer gone"))?;
            }
        }
        (0..self.n)
            .map(|p| {
                if p == self.me {
                    Ok(v.to_vec())
                } else {
                    self.rx[p]
                        .recv()
                        .map_err(|_| Error::invalid(format!("rank {p} hung up")))
                }
            })
            .collect()
    }
    fn barrier(&mut self) {
        self.barrier.wait();
    }
    fn fail(&self, e: Error) -> Error {
        e
    }
}
