//! Record headers of a ROS 1 bag: a sequence of `uint32 length, "name=value"` fields.

/// Op codes of bag format 2.0 records.
pub(crate) mod op {
    pub(crate) const MESSAGE_DATA: u8 = 0x02;
    pub(crate) const BAG_HEADER: u8 = 0x03;
    pub(crate) const INDEX_DATA: u8 = 0x04;
    pub(crate) const CHUNK: u8 = 0x05;
    pub(crate) const CHUNK_INFO: u8 = 0x06;
    pub(crate) const CONNECTION: u8 = 0x07;
}

/// The fields of one header, borrowed from its bytes.
pub(crate) struct Fields<'a>(Vec<(&'a [u8], &'a [u8])>);

impl<'a> Fields<'a> {
    /// Splits a header; `Err` names what is wrong.
    pub(crate) fn parse(mut bytes: &'a [u8]) -> Result<Self, String> {
        let mut fields = Vec::new();
        while !bytes.is_empty() {
            let len = bytes
                .get(..4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
                .ok_or("a header field length is cut off")?;
            let field = bytes
                .get(4..4usize.saturating_add(len))
                .ok_or_else(|| format!("a header field claims {len} bytes, more than are left"))?;
            let eq = field
                .iter()
                .position(|&b| b == b'=')
                .ok_or("a header field has no `=`")?;
            fields.push((&field[..eq], &field[eq + 1..]));
            bytes = &bytes[4 + len..];
        }
        Ok(Fields(fields))
    }

    /// The value of field `name`, if present.
    pub(crate) fn get(&self, name: &str) -> Option<&'a [u8]> {
        self.0
            .iter()
            .find(|(n, _)| *n == name.as_bytes())
            .map(|(_, v)| *v)
    }

    /// A required field.
    pub(crate) fn require(&self, name: &str) -> Result<&'a [u8], String> {
        self.get(name)
            .ok_or_else(|| format!("the record header has no `{name}` field"))
    }

    /// A required 1-byte field.
    pub(crate) fn u8(&self, name: &str) -> Result<u8, String> {
        match self.require(name)? {
            [b] => Ok(*b),
            v => Err(format!("`{name}` has {} bytes, not 1", v.len())),
        }
    }

    /// A required little-endian 4-byte field.
    pub(crate) fn u32(&self, name: &str) -> Result<u32, String> {
        let v = self.require(name)?;
        <[u8; 4]>::try_from(v)
            .map(u32::from_le_bytes)
            .map_err(|_| format!("`{name}` has {} bytes, not 4", v.len()))
    }

    /// A required text field.
    pub(crate) fn text(&self, name: &str) -> Result<String, String> {
        String::from_utf8(self.require(name)?.to_vec())
            .map_err(|_| format!("`{name}` is not UTF-8"))
    }
}

/// Appends one `name=value` field to a header being written.
pub(crate) fn push_field(out: &mut Vec<u8>, name: &str, value: &[u8]) {
    let len = u32::try_from(name.len() + 1 + value.len()).unwrap_or(u32::MAX);
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(name.as_bytes());
    out.push(b'=');
    out.extend_from_slice(value);
}

/// Appends a whole record: header length, header, data length, data.
pub(crate) fn push_record(out: &mut Vec<u8>, header: &[u8], data: &[u8]) {
    out.extend_from_slice(
        &u32::try_from(header.len())
            .unwrap_or(u32::MAX)
            .to_le_bytes(),
    );
    out.extend_from_slice(header);
    out.extend_from_slice(&u32::try_from(data.len()).unwrap_or(u32::MAX).to_le_bytes());
    out.extend_from_slice(data);
}
