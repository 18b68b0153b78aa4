// The parts of Node-RED's runtime API the palette uses, declared here rather
// than pulled from @types/node-red (large, and behind Node-RED 4's API).
// Global: JSDoc in the palette's files names them as `NodeRed.X`.

declare namespace NodeRed {
    /** A node's status badge. */
    interface NodeStatus {
        fill?: "red" | "green" | "yellow" | "blue" | "grey";
        shape?: "ring" | "dot";
        text?: string;
    }

    /** A msg as it travels; the palette reads and writes its own properties. */
    interface Message {
        _msgid?: string;
        topic?: string;
        payload?: any;
        [key: string]: any;
    }

    type Send = (msg: Message | null | (Message | Message[] | null)[]) => void;
    type Done = (err?: Error) => void;

    /** A node instance, with the properties each of the palette's nodes adds. */
    interface Node {
        id: string;
        type: string;
        z?: string;
        name?: string;
        status(status: NodeStatus | {}): void;
        send(msg: Message | null | (Message | Message[] | null)[]): void;
        on(event: "input", handler: (msg: Message, send: Send, done: Done) => void): void;
        on(event: "close", handler: (removed: boolean, done: () => void) => void): void;
        log(text: string): void;
        warn(text: string): void;
        error(text: string | Error, msg?: Message | null): void;
        debug(text: string): void;
        trace(text: string): void;
        context(): NodeContext;
        [key: string]: any;
    }

    /** A node's context store: synchronous without a callback, else through it. */
    interface NodeContext {
        get(key: string, store?: string, callback?: (err: Error | null, value: any) => void): any;
        set(key: string, value: any, store?: string, callback?: (err: Error | null) => void): void;
        [key: string]: any;
    }

    /** A node's properties as the editor saved them. */
    interface NodeProps {
        id: string;
        type: string;
        name?: string;
        [key: string]: any;
    }

    type NodeConstructor = (this: Node, props: NodeProps) => void;

    interface Log {
        info(text: string): void;
        warn(text: string): void;
        error(text: string): void;
        debug(text: string): void;
        trace(text: string): void;
        [level: string]: (text: string) => void;
    }

    /** The `RED` object a node module's function receives. */
    interface RED {
        nodes: {
            createNode(node: Node, props: NodeProps): void;
            registerType(type: string, constructor: NodeConstructor, options?: object): void;
            getNode(id: string): Node | null;
            [key: string]: any;
        };
        log: Log;
        settings: { [key: string]: any };
        events: { on(event: string, handler: (...args: any[]) => void): void; removeListener(event: string, handler: (...args: any[]) => void): void; [key: string]: any };
        util: { [key: string]: any };
        httpAdmin: any;
        auth: any;
        /** Translates a message key of the palette's catalogue. */
        _(key: string, substitutions?: object): string;
        [key: string]: any;
    }
}

declare namespace WebAssembly {
    /** What a trap throws (Node has it; TypeScript's lib declares it only with the DOM). */
    class RuntimeError extends Error {}
}
