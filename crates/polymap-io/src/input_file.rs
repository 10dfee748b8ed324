//! Files that must be files: a saved map, a configuration, a rosbag2 part. A path naming
//! something else — a device such as `/dev/zero`, a FIFO, a socket, a folder — is refused with
//! what it is, before it is opened (opening a FIFO waits for a writer), and a file read whole is
//! read up to a limit, so neither an endless input nor a huge file exhausts memory.
//!
//! ```
//! use polymap_io::input_file::read_regular_to_string;
//! let dir = std::env::temp_dir().join(format!("polymap-input-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("a.toml");
//! std::fs::write(&path, "x = 1\n").unwrap();
//! assert_eq!(read_regular_to_string(&path, 100).unwrap(), "x = 1\n");
//! assert!(read_regular_to_string(&path, 3).unwrap_err().to_string().contains("more than"));
//! assert!(read_regular_to_string(&dir, 100).unwrap_err().to_string().contains("a folder"));
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

use std::fs::{File, FileType};
use std::io::{self, Read};
use std::path::Path;

/// What a file type is, in words, when it is not a regular file ("a character device", "a
/// FIFO (named pipe)", "a socket", "a folder", …).
pub fn kind_of(t: &FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a folder"
    } else {
        "not a regular file"
    }
}

/// Checks that `path` (links followed) is a regular file, without opening it. The error says
/// what it is instead (kind [`io::ErrorKind::InvalidInput`]).
pub fn check_regular(path: &Path) -> io::Result<std::fs::Metadata> {
    let meta = std::fs::metadata(path)?;
    if meta.is_file() {
        return Ok(meta);
    }
    Err(io::Error::new(
        io::ErrorKind::InvalidInput,
        format!("{}, not a regular file", kind_of(&meta.file_type())),
    ))
}

/// Opens `path` for reading after [`check_regular`].
pub fn open_regular(path: &Path) -> io::Result<File> {
    check_regular(path)?;
    File::open(path)
}

/// The whole of `input`, refused (kind [`io::ErrorKind::FileTooLarge`]) once it holds more
/// than `max_bytes`: at most `max_bytes + 1` bytes are read, whatever the input's length.
pub fn read_bounded(input: impl Read, max_bytes: u64) -> io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    input
        .take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(io::Error::new(
            io::ErrorKind::FileTooLarge,
            format!("more than the {max_bytes} bytes a file of this kind may hold"),
        ));
    }
    Ok(bytes)
}

/// The whole of the regular file `path`, refused (kind [`io::ErrorKind::FileTooLarge`]) when
/// it holds more than `max_bytes`.
pub fn read_regular(path: &Path, max_bytes: u64) -> io::Result<Vec<u8>> {
    let meta = check_regular(path)?;
    if meta.len() > max_bytes {
        return Err(io::Error::new(
            io::ErrorKind::FileTooLarge,
            format!(
                "{} bytes, more than the {max_bytes} bytes a file of this kind may hold",
                meta.len()
            ),
        ));
    }
    // The file may grow while it is read: the limit holds for what is read, too.
    read_bounded(File::open(path)?, max_bytes)
}

/// [`read_regular`] as UTF-8 text.
pub fn read_regular_to_string(path: &Path, max_bytes: u64) -> io::Result<String> {
    String::from_utf8(read_regular(path, max_bytes)?)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidData, "not UTF-8 text"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn devices_and_links_to_them_are_refused_by_kind() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("map.json");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        for path in [Path::new("/dev/zero"), &link] {
            let e = read_regular(path, 1 << 20).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
            assert!(e.to_string().contains("a character device"), "{e}");
        }
    }

    #[test]
    fn a_file_over_the_limit_is_refused_with_its_size() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big");
        std::fs::write(&path, vec![b'x'; 101]).unwrap();
        let e = read_regular(&path, 100).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert!(e.to_string().starts_with("101 bytes"), "{e}");
        assert_eq!(read_regular(&path, 101).unwrap().len(), 101);
    }
}
