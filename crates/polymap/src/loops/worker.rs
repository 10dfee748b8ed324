//! The loop thread: completed nodes go to the graph on a second thread (with
//! `loops.background`), or are worked here when no thread runs; each node's outcome is
//! published in a slot the mapper waits on.

use std::collections::VecDeque;
use std::panic::AssertUnwindSafe;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex, OnceLock};

use super::LoopFailure;
use super::nodes::{JobResult, NodeDone, NodeGraph};

/// What the graph publishes for one node: its outcome, or the failure that stopped it.
pub(super) type Outcome = Result<JobResult, LoopFailure>;

/// A node on its way to the thread, with the slot for its outcome.
type Job = (NodeDone, Arc<OnceLock<Outcome>>);

/// An outcome on its way from the graph.
#[derive(Debug, Clone)]
pub(super) struct Pending {
    /// The node it is for.
    pub(super) node: usize,
    /// Set once, when the graph is done with the node.
    pub(super) result: Arc<OnceLock<Outcome>>,
}

/// The graph and, once started, the thread that works on it.
#[derive(Debug)]
pub(super) struct Worker {
    graph: Arc<Mutex<NodeGraph>>,
    background: bool,
    thread: Option<Sender<Job>>,
    /// Outcomes not yet taken in, oldest first.
    pub(super) pending: VecDeque<Pending>,
}

impl Clone for Worker {
    /// Waits for the graph to finish the nodes handed to it, then copies it (the copy works
    /// without a thread until it needs one).
    fn clone(&self) -> Self {
        for p in &self.pending {
            p.result.wait();
        }
        Worker {
            graph: Arc::new(Mutex::new(lock(&self.graph).clone())),
            background: self.background,
            thread: None,
            pending: self.pending.clone(),
        }
    }
}

impl Worker {
    /// A worker for `graph`, on a thread of its own (started on first use) with `background`.
    pub(super) fn new(graph: NodeGraph, background: bool) -> Self {
        Worker {
            graph: Arc::new(Mutex::new(graph)),
            background,
            thread: None,
            pending: VecDeque::new(),
        }
    }

    /// Gives a completed node to the graph: to the thread with `background` (started on
    /// first use), here otherwise or when no thread can be started.
    pub(super) fn hand_over(&mut self, done: NodeDone) {
        let result = Arc::new(OnceLock::new());
        self.pending.push_back(Pending {
            node: done.node,
            result: Arc::clone(&result),
        });
        if self.background && self.thread.is_none() {
            self.thread = self.start();
        }
        let done = match &self.thread {
            Some(tx) => match tx.send((done, Arc::clone(&result))) {
                Ok(()) => return,
                // The thread is gone (it cannot be, short of a crash): work here.
                Err(e) => {
                    self.thread = None;
                    e.0.0
                }
            },
            None => done,
        };
        run_node(&self.graph, done, &result);
    }

    /// Starts the thread; `None` when the system refuses one.
    fn start(&self) -> Option<Sender<Job>> {
        let (tx, rx) = std::sync::mpsc::channel::<Job>();
        let graph = Arc::clone(&self.graph);
        std::thread::Builder::new()
            .name("polymap-loops".into())
            .spawn(move || {
                for (done, slot) in rx {
                    run_node(&graph, done, &slot);
                }
            })
            .ok()
            .map(|_| tx)
    }
}

#[cfg(test)]
impl Worker {
    /// Queues an outcome as if the graph had published it for `node`.
    pub(super) fn push_outcome(&mut self, node: usize, outcome: Outcome) {
        let result = Arc::new(OnceLock::new());
        let _ = result.set(outcome);
        self.pending.push_back(Pending { node, result });
    }
}

impl Worker {
    /// Reads the graph (waiting for the thread's work on it to finish).
    pub(super) fn read<R>(&self, f: impl FnOnce(&NodeGraph) -> R) -> R {
        f(&lock(&self.graph))
    }
}

/// The graph, also after a panic while it was locked (the failure is published, and loop
/// closure stops: see [`super::LoopCloser::failure`]).
fn lock(graph: &Mutex<NodeGraph>) -> std::sync::MutexGuard<'_, NodeGraph> {
    graph.lock().unwrap_or_else(|e| e.into_inner())
}

/// Runs the graph's work for one node and publishes the outcome.
fn run_node(graph: &Mutex<NodeGraph>, done: NodeDone, slot: &OnceLock<Outcome>) {
    let node = done.node;
    publish(slot, node, || lock(graph).add(done));
}

/// Runs `job` for `node` and publishes its result in `slot`, or, when it panics, a
/// [`LoopFailure`] with the panic's message: a failure is never lost.
fn publish(slot: &OnceLock<Outcome>, node: usize, job: impl FnOnce() -> JobResult) {
    let outcome = std::panic::catch_unwind(AssertUnwindSafe(job)).map_err(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".to_string());
        LoopFailure { node, message }
    });
    // Every slot is fresh and set here only, once.
    let first = slot.set(outcome).is_ok();
    debug_assert!(first, "the outcome of node {node} was published twice");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_is_published_as_a_failure_with_its_message() {
        let slot = OnceLock::new();
        publish(&slot, 7, || panic!("index out of bounds"));
        let failure = slot.get().unwrap().as_ref().unwrap_err();
        assert_eq!(failure.node, 7);
        assert_eq!(failure.message, "index out of bounds");
        let slot = OnceLock::new();
        publish(&slot, 8, JobResult::default);
        assert!(slot.get().unwrap().is_ok());
    }
}
