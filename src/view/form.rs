//! The viewer's parameters as a form sends them (`application/x-www-form-urlencoded`, the
//! same in a query string): `name=value` pairs joined by `&`, `+` for a space, `%XX` for a
//! byte.

/// The pairs of `text` in order (a name without `=` has an empty value), or what is wrong
/// with it.
pub fn parse(text: &str) -> Result<Vec<(String, String)>, String> {
    text.split('&')
        .filter(|p| !p.is_empty())
        .map(|pair| {
            let (name, value) = pair.split_once('=').unwrap_or((pair, ""));
            Ok((decode(name)?, decode(value)?))
        })
        .collect()
}

/// One name or value, decoded.
fn decode(s: &str) -> Result<String, String> {
    let mut bytes = Vec::with_capacity(s.len());
    let mut it = s.bytes();
    while let Some(b) = it.next() {
        match b {
            b'+' => bytes.push(b' '),
            b'%' => {
                let hex = [it.next(), it.next()];
                let digit = |d: Option<u8>| d.and_then(|d| (d as char).to_digit(16));
                match (digit(hex[0]), digit(hex[1])) {
                    (Some(h), Some(l)) => bytes.push((h * 16 + l) as u8),
                    _ => return Err(format!("`{s}`: `%` must be followed by two hex digits")),
                }
            }
            _ => bytes.push(b),
        }
    }
    String::from_utf8(bytes).map_err(|_| format!("`{s}`: not UTF-8 once decoded"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_are_decoded_in_order() {
        let got = parse("backend=avx2&orbit=0.1%2C-0.2&&name+x=a+b&flag").unwrap();
        let want = [
            ("backend", "avx2"),
            ("orbit", "0.1,-0.2"),
            ("name x", "a b"),
            ("flag", ""),
        ];
        assert_eq!(got.len(), want.len());
        for ((n, v), (wn, wv)) in got.iter().zip(want) {
            assert_eq!((n.as_str(), v.as_str()), (wn, wv));
        }
        assert!(parse("").unwrap().is_empty());
    }

    #[test]
    fn broken_escapes_are_refused() {
        for bad in ["a=%", "a=%4", "a=%zz", "%ff=1", "a=%c3%28"] {
            let e = parse(bad).unwrap_err();
            assert!(
                e.contains("hex digits") || e.contains("UTF-8"),
                "{bad}: {e}"
            );
        }
    }
}
