//! One HTTP/1.1 exchange on a connection, within the limits a local viewer needs: a request
//! header of at most [`MAX_HEADER`] bytes (httparse parses it), a body of at most
//! [`MAX_BODY`] bytes given by `Content-Length`, and one request per connection (every
//! response closes it, so a slow or idle client holds a handler only until its timeout).

use std::io::{self, Read, Write};

/// The largest request header read (request line and fields).
pub const MAX_HEADER: usize = 8 * 1024;
/// The largest request body read.
pub const MAX_BODY: usize = 64 * 1024;
/// The most header fields read.
const MAX_FIELDS: usize = 64;

/// A request, read whole.
#[derive(Debug)]
pub struct Request {
    pub method: String,
    /// The request target as sent: the path and, after `?`, the query.
    pub target: String,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Request {
    /// The first field named `name` (case-insensitive).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    /// The target's path (before any `?`), undecoded.
    pub fn path(&self) -> &str {
        self.target.split_once('?').map_or(&self.target, |(p, _)| p)
    }

    /// The target's query (after `?`), undecoded; empty without one.
    pub fn query(&self) -> &str {
        self.target.split_once('?').map_or("", |(_, q)| q)
    }
}

/// A response.
#[derive(Debug)]
pub struct Response {
    pub status: u16,
    pub content_type: &'static str,
    pub body: Vec<u8>,
    /// Fields besides the ones every response has.
    pub headers: Vec<(&'static str, String)>,
}

impl Response {
    /// A body of `content_type`.
    pub fn new(status: u16, content_type: &'static str, body: impl Into<Vec<u8>>) -> Response {
        Response {
            status,
            content_type,
            body: body.into(),
            headers: Vec::new(),
        }
    }

    /// A message in plain text (errors say what was wrong in it).
    pub fn text(status: u16, message: impl Into<String>) -> Response {
        let mut m = message.into();
        m.push('\n');
        Response::new(status, "text/plain; charset=utf-8", m)
    }

    /// One more header field.
    pub fn with_header(mut self, name: &'static str, value: impl Into<String>) -> Response {
        self.headers.push((name, value.into()));
        self
    }

    /// Writes the response: status line, fields, body. Every response closes the
    /// connection, and none may be cached (the frame changes after every pass).
    pub fn write_to(&self, out: &mut impl Write) -> io::Result<()> {
        let mut head = format!(
            "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\n\
             Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nConnection: close\r\n",
            self.status,
            reason(self.status),
            self.content_type,
            self.body.len()
        );
        for (n, v) in &self.headers {
            head.push_str(&format!("{n}: {v}\r\n"));
        }
        head.push_str("\r\n");
        out.write_all(head.as_bytes())?;
        out.write_all(&self.body)?;
        out.flush()
    }
}

/// Why no request came: the error response to send, or nothing (the client went away or
/// timed out before sending anything).
#[derive(Debug)]
pub enum ReadError {
    Respond(Response),
    Gone,
}

/// Reads one request from `stream`, within the limits.
pub fn read_request(stream: &mut (impl Read + Write)) -> Result<Request, ReadError> {
    let mut buf: Vec<u8> = Vec::with_capacity(1024);
    let mut chunk = [0u8; 4096];
    let (mut request, header_len) = loop {
        let mut fields = [httparse::EMPTY_HEADER; MAX_FIELDS];
        let mut parsed = httparse::Request::new(&mut fields);
        match parsed.parse(&buf) {
            Ok(httparse::Status::Complete(n)) => {
                if n > MAX_HEADER {
                    return Err(too_large_header());
                }
                break (owned(&parsed), n);
            }
            Ok(httparse::Status::Partial) if buf.len() > MAX_HEADER => {
                return Err(too_large_header());
            }
            Ok(httparse::Status::Partial) => {}
            Err(httparse::Error::TooManyHeaders) => {
                return Err(ReadError::Respond(Response::text(
                    431,
                    format!("request header fields too large: more than {MAX_FIELDS} fields"),
                )));
            }
            Err(e) => {
                return Err(ReadError::Respond(Response::text(
                    400,
                    format!("malformed request: {e}"),
                )));
            }
        }
        let n = match stream.read(&mut chunk) {
            Ok(0) => return Err(ReadError::Gone),
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(_) if buf.is_empty() => return Err(ReadError::Gone),
            Err(e) => {
                return Err(ReadError::Respond(Response::text(
                    408,
                    format!("the request header did not arrive in time ({e})"),
                )));
            }
        };
        buf.extend_from_slice(&chunk[..n]);
    };

    if request.header("Transfer-Encoding").is_some() {
        return Err(ReadError::Respond(Response::text(
            411,
            "send the body with a Content-Length (chunked bodies are not read)",
        )));
    }
    let length = match request.header("Content-Length") {
        None => 0,
        Some(v) => v.trim().parse::<u64>().map_err(|_| {
            ReadError::Respond(Response::text(
                400,
                format!("Content-Length `{v}` is not a number of bytes"),
            ))
        })?,
    };
    if length > MAX_BODY as u64 {
        return Err(ReadError::Respond(Response::text(
            413,
            format!(
                "request body of {length} bytes is over the limit of {} KiB",
                MAX_BODY / 1024
            ),
        )));
    }
    let length = length as usize;
    let mut body = buf[header_len..].to_vec();
    if body.len() < length
        && request
            .header("Expect")
            .is_some_and(|e| e.eq_ignore_ascii_case("100-continue"))
    {
        let _ = stream.write_all(b"HTTP/1.1 100 Continue\r\n\r\n");
    }
    while body.len() < length {
        match stream.read(&mut chunk) {
            Ok(0) => return Err(ReadError::Gone),
            Ok(n) => body.extend_from_slice(&chunk[..n]),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => return Err(ReadError::Gone),
        }
    }
    body.truncate(length);
    request.body = body;
    Ok(request)
}

fn too_large_header() -> ReadError {
    ReadError::Respond(Response::text(
        431,
        format!(
            "request header fields too large: over {} KiB",
            MAX_HEADER / 1024
        ),
    ))
}

/// The parsed header as owned strings (a field's value that is not UTF-8 is kept lossily:
/// the viewer reads only ASCII fields).
fn owned(r: &httparse::Request<'_, '_>) -> Request {
    Request {
        method: r.method.unwrap_or_default().to_owned(),
        target: r.path.unwrap_or_default().to_owned(),
        headers: r
            .headers
            .iter()
            .map(|h| {
                (
                    h.name.to_owned(),
                    String::from_utf8_lossy(h.value).into_owned(),
                )
            })
            .collect(),
        body: Vec::new(),
    }
}

/// The reason phrase of the statuses the viewer sends.
fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        411 => "Length Required",
        413 => "Content Too Large",
        415 => "Unsupported Media Type",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        503 => "Service Unavailable",
        _ => "",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    /// A connection whose input is `input` and whose output is kept.
    struct Pipe {
        input: Cursor<Vec<u8>>,
        output: Vec<u8>,
    }

    impl Read for Pipe {
        fn read(&mut self, b: &mut [u8]) -> io::Result<usize> {
            self.input.read(b)
        }
    }

    impl Write for Pipe {
        fn write(&mut self, b: &[u8]) -> io::Result<usize> {
            self.output.extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    fn read(input: &[u8]) -> Result<Request, ReadError> {
        read_request(&mut Pipe {
            input: Cursor::new(input.to_vec()),
            output: Vec::new(),
        })
    }

    fn status(r: Result<Request, ReadError>) -> u16 {
        match r {
            Ok(_) => 200,
            Err(ReadError::Respond(r)) => r.status,
            Err(ReadError::Gone) => 0,
        }
    }

    #[test]
    fn a_request_with_a_body_is_read_whole() {
        let r =
            read(b"POST /camera?x=1 HTTP/1.1\r\nHost: a\r\nContent-Length: 7\r\n\r\ndolly=2tail")
                .unwrap();
        assert_eq!(r.method, "POST");
        assert_eq!((r.path(), r.query()), ("/camera", "x=1"));
        assert_eq!(r.header("content-length"), Some("7"));
        assert_eq!(r.body, b"dolly=2");
    }

    #[test]
    fn limits_and_malformed_requests_get_their_statuses() {
        let mut big = b"GET / HTTP/1.1\r\nX-Big: ".to_vec();
        big.extend(std::iter::repeat_n(b'a', MAX_HEADER));
        big.extend_from_slice(b"\r\n\r\n");
        assert_eq!(status(read(&big)), 431);
        let body = format!(
            "POST /settings HTTP/1.1\r\nContent-Length: {}\r\n\r\n",
            MAX_BODY + 1
        );
        assert_eq!(status(read(body.as_bytes())), 413);
        assert_eq!(
            status(read(
                b"POST / HTTP/1.1\r\nContent-Length: 99999999999999999999\r\n\r\n"
            )),
            400
        );
        assert_eq!(
            status(read(
                b"POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n"
            )),
            411
        );
        assert_eq!(status(read(b"GET / HTTP/1.1\r\nBad Field\r\n\r\n")), 400);
        assert_eq!(status(read(b"\x01\x02 nonsense\r\n\r\n")), 400);
        assert_eq!(status(read(b"GET / HTT")), 0, "the client went away");
        assert_eq!(status(read(b"")), 0);
    }

    #[test]
    fn responses_close_the_connection_and_forbid_caching() {
        let mut out = Vec::new();
        Response::text(404, "no such page")
            .with_header("Allow", "GET")
            .write_to(&mut out)
            .unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.starts_with("HTTP/1.1 404 Not Found\r\n"), "{text}");
        for field in [
            "Connection: close",
            "Cache-Control: no-store",
            "Allow: GET",
            "Content-Length: 13",
        ] {
            assert!(text.contains(field), "{field}: {text}");
        }
        assert!(text.ends_with("\r\n\r\nno such page\n"));
    }
}
