//! Integration tests, one binary. Tests reading `../shared/datasets` skip with a message when
//! the folder is absent (a fresh clone has no datasets).

mod datasets;
