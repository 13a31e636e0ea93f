//! Line and token functions shared by the text readers (OBJ, OFF, ASCII STL). They work on bytes,
//! so a file that is not UTF-8 fails at the token that is not a number, with its line.

use std::str::FromStr;

use crate::error::Location;

/// The file's lines, numbered from 1, without their `\n` (a `\r` before it is whitespace).
pub(super) fn lines(bytes: &[u8]) -> impl Iterator<Item = (Location, &[u8])> {
    bytes.split(|&b| b == b'\n').enumerate().map(|(n, line)| (Location::Line(n + 1), line))
}

/// A line without its `#` comment.
pub(super) fn strip_comment(line: &[u8]) -> &[u8] {
    line.split(|&b| b == b'#').next().unwrap_or_default()
}

/// The whitespace-separated tokens of a line.
pub(super) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(u8::is_ascii_whitespace).filter(|t| !t.is_empty())
}

/// A token parsed as a number (or anything else `FromStr`), if it is one.
pub(super) fn parse<T: FromStr>(token: &[u8]) -> Option<T> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

/// A token as text for a message, cut short if long.
pub(super) fn show(token: &[u8]) -> String {
    String::from_utf8_lossy(&token[..token.len().min(40)]).into_owned()
}

/// Three coordinates from the next tokens; `what` names them in the message.
pub(super) fn position<'a>(
    tokens: &mut impl Iterator<Item = &'a [u8]>,
    what: &str,
) -> Result<[f64; 3], String> {
    let mut p = [0.0; 3];
    for (axis, c) in p.iter_mut().enumerate() {
        let token = tokens
            .next()
            .ok_or_else(|| format!("{what} needs 3 coordinates, this one has {axis}"))?;
        *c = parse(token)
            .ok_or_else(|| format!("{what} coordinate '{}' is not a number", show(token)))?;
    }
    Ok(p)
}
