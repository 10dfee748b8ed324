//! The loop thread: completed nodes go to the graph on a second thread (with
//! `loops.background`), or are worked here when no thread runs; each node's outcome is
//! published in a slot the mapper waits on.

use std::collections::VecDeque;
use std::panic::AssertUnwindSafe;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex, OnceLock};

use super::nodes::{JobResult, NodeDone, NodeGraph};

/// An outcome on its way from the graph.
#[derive(Debug, Clone)]
pub(super) struct Pending {
    /// The node it is for.
    pub(super) node: usize,
    /// Set once, when the graph is done with the node.
    pub(super) result: Arc<OnceLock<JobResult>>,
}

/// The graph and, once started, the thread that works on it.
#[derive(Debug)]
pub(super) struct Worker {
    graph: Arc<Mutex<NodeGraph>>,
    background: bool,
    thread: Option<Sender<(NodeDone, Arc<OnceLock<JobResult>>)>>,
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
    fn start(&self) -> Option<Sender<(NodeDone, Arc<OnceLock<JobResult>>)>> {
        let (tx, rx) = std::sync::mpsc::channel::<(NodeDone, Arc<OnceLock<JobResult>>)>();
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

/// The graph, also after a panic while it was locked (the panicking job's node then simply
/// has no loop edges).
fn lock(graph: &Mutex<NodeGraph>) -> std::sync::MutexGuard<'_, NodeGraph> {
    graph.lock().unwrap_or_else(|e| e.into_inner())
}

/// Runs the graph's work for one node and publishes the outcome (empty after a panic).
fn run_node(graph: &Mutex<NodeGraph>, done: NodeDone, slot: &OnceLock<JobResult>) {
    let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| lock(graph).add(done)));
    let _ = slot.set(outcome.unwrap_or_default());
}
