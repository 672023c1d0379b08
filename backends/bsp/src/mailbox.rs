//! The intersection cache (mailbox) of paper section 3: a triangle referenced by several
//! leaves is tested once per ray (or once per lane of a packet). Direct-mapped by the
//! triangle's index; a collision only costs a repeated test, never a wrong answer.

/// Slots per cache (a power of two).
pub(crate) const MAILBOX_SLOTS: usize = 16;

/// The cache of one ray.
pub(crate) struct Mailbox1 {
    ids: [u32; MAILBOX_SLOTS],
}

impl Mailbox1 {
    #[inline(always)]
    pub fn new() -> Self {
        Self {
            ids: [u32::MAX; MAILBOX_SLOTS],
        }
    }

    /// True when `id` was tested already; otherwise remembers it.
    #[inline(always)]
    pub fn seen(&mut self, id: u32) -> bool {
        let slot = &mut self.ids[id as usize & (MAILBOX_SLOTS - 1)];
        if *slot == id {
            true
        } else {
            *slot = id;
            false
        }
    }
}

/// The cache of one packet: per slot the triangle and the lanes it was tested for.
pub(crate) struct MailboxP {
    ids: [u32; MAILBOX_SLOTS],
    lanes: [u32; MAILBOX_SLOTS],
}

impl MailboxP {
    pub const EMPTY: MailboxP = MailboxP {
        ids: [u32::MAX; MAILBOX_SLOTS],
        lanes: [0; MAILBOX_SLOTS],
    };

    #[inline(always)]
    pub fn new() -> Self {
        Self::EMPTY
    }

    /// The lanes of `lanes` (a bitmask) for which `id` still has to be tested, and remembers
    /// them as tested.
    #[inline(always)]
    pub fn untested(&mut self, id: u32, lanes: u32) -> u32 {
        let s = id as usize & (MAILBOX_SLOTS - 1);
        if self.ids[s] == id {
            let new = lanes & !self.lanes[s];
            self.lanes[s] |= new;
            new
        } else {
            self.ids[s] = id;
            self.lanes[s] = lanes;
            lanes
        }
    }
}
